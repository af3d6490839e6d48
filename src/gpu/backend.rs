//! The GPU backend: a run's device, pipelines and buffers, and the `Backend` it implements.
//! Substeps are encoded into one submission; the host waits on the GPU only when a snapshot is
//! due, and the next frame steps while a snapshot is read back.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use super::context::{DeviceError, GpuContext};
use super::encode::Dispatcher;
use super::fused_plan::{self, ExplicitPath};
use super::implicit::{Budgets, Path};
use super::layout::FrameSolve;
use super::limits::check_fits;
use super::loop_budget::LoopBudget;
use super::multigrid::Layout as MultigridLayout;
use super::pipelines::{Layouts, Needed, Pipelines};
use super::plan::StepPaths;
use super::readback::Pending;
use super::resources::{ResourcePlan, Resources};
use super::sizing::{self, why_not_in_group};
use super::stages::{Clock, StageSlots};
use super::tuning::{RunPaths, Tuning, specialise};
use crate::backend::{Backend, BackendError, StopFlags};
use crate::integrator::{Integrator, Over, Step};
use crate::model::Model;
use crate::state::{Ledger, Snapshot, State, StepStats};

/// Frames whose records implicit Euler's budgets follow (per-pass path).
pub(super) const RECENT_FRAMES: usize = 8;

pub struct GpuBackend {
    pub(super) ctx: GpuContext,
    pub(super) model: Arc<Model>,
    pub(super) integrator: Integrator,
    pub(super) clock: Clock,
    /// Energy folded out of the per-mass ledger at each snapshot, summed in f64.
    pub(super) ledger: Ledger,
    pub(super) verlet_primed: bool,
    pub(super) pipelines: Pipelines,
    pub(super) layouts: Layouts,
    pub(super) resources: Resources,
    pub(super) stages: StageSlots,
    /// Bytes of GPU memory held by the simulation's buffers.
    pub memory_bytes: u64,
    pub(super) advance_started: Option<Instant>,
    /// Snapshots asked for and not yet collected, oldest first.
    pub(super) pending: VecDeque<Pending>,
    /// Snapshots returned by the recorder, their buffers reused.
    pub(super) spare: Vec<Snapshot>,
    /// Implicit Euler: how its steps run, and the budgets the next frame is encoded with (the
    /// path of a dispatch per pass).
    pub(super) implicit_path: Option<Path>,
    pub(super) budgets: Budgets,
    /// What the last few frames' steps took (the budgets follow the most of them).
    pub(super) recent_frames: VecDeque<FrameSolve>,
    /// Frames replayed with larger budgets since the run began.
    pub(super) replays: u64,
    /// Explicit integrators: fused steps or a pass per stage (`fused_plan::fused_links`).
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
        implicit: Path,
        explicit: ExplicitPath,
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
                fused_plan::fused_links(&model, integrator, storage_buffers).ok()
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
        let sweeps = integrator.scheme().sweeps().map(|s| s.over);
        let needed = Needed {
            implicit: implicit.then_some(path),
            multigrid: multigrid.is_some(),
            restarts: implicit
                && crate::physics::BackwardStep::restarts_at_impacts(integrator, &model.effects),
            springs_change: model.effects.springs_change(),
            mass_contact: model.effects.self_collision.is_some(),
            xpbd: sweeps == Some(Over::Springs),
            vbd: sweeps == Some(Over::Masses),
            fused: explicit == ExplicitPath::Fused,
            fused_in_group: explicit == ExplicitPath::InGroup,
        };
        let layouts = Layouts::new(device, needed);
        // The per-pass kernels' grid; the one-workgroup step has none.
        let grid = |path| match path {
            Path::Passes => sizing::solver_groups(model.mass_count(), ctx.info.device_type),
            Path::InGroup => 1,
        };
        let mut resources = Resources::new(
            device,
            &ctx.limits,
            &model,
            step,
            &ResourcePlan {
                layouts: &layouts,
                links: links.as_ref(),
                implicit: needed.implicit.map(|path| (path, grid(path))),
                multigrid: multigrid.as_ref(),
                stage_c: fused_plan::keeps_stage_c(integrator),
            },
        );
        let run = RunPaths {
            model: model.as_ref(),
            step,
            explicit,
            implicit: needed.implicit,
        };
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
    /// The paths this run's steps take.
    pub fn step_paths(&self) -> StepPaths {
        StepPaths {
            explicit: self.explicit_path,
            implicit: self.implicit_path,
            sweeps_in_group: self.sweeps_in_group(),
            multigrid_levels: self.multigrid_levels(),
        }
    }

    pub fn sweeps_in_group(&self) -> bool {
        self.resources.sweeps().one_group
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
