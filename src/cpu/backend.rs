//! `CpuBackend`: the `Backend` the CPU reference implements, as `gpu/backend.rs` is the GPU's.
//! It steps through the fused one-pass step where that serves the model and integrator
//! (`FusedStep::serves`), and through the general path (`integrate::step`: forces, update,
//! projection, spring changes) otherwise.

use super::chunks::{PARALLEL_MIN_MASSES, in_pool};
use super::collide::project_contacts;
use super::fused::{FusedStep, Simd};
use super::integrate;
use super::reduce::{compute_energies, compute_strain};
use crate::backend::{Backend, BackendError, Internal, StopFlags, find_divergence};
use crate::integrator::{Integrator, Step};
use crate::model::Model;
use crate::physics::Preconditioner;
use crate::state::{RuleOutcome, Snapshot, State, StepStats};

pub struct CpuBackend {
    model: std::sync::Arc<Model>,
    integrator: Integrator,
    dt: f32,
    state: State,
    scratch: integrate::Scratch,
    pending: std::collections::VecDeque<Snapshot>,
    /// Snapshots returned by the recorder, their buffers reused.
    spare: Vec<Snapshot>,
    /// The one-pass step, for the models and integrators it serves.
    fused: Option<FusedStep>,
}

impl CpuBackend {
    pub fn new(model: std::sync::Arc<Model>, step: Step) -> Self {
        let Step {
            integrator,
            dt_secs,
            ..
        } = step;
        let fused = FusedStep::serves(&model, integrator)
            .then(|| FusedStep::new(&model, integrator, Simd::Best));
        Self {
            fused,
            state: model.initial.clone(),
            scratch: integrate::Scratch::new(&model, step),
            pending: std::collections::VecDeque::new(),
            spare: Vec::new(),
            model,
            integrator,
            dt: dt_secs as f32,
        }
    }

    /// Step with `kernel`'s lanes where the fused step serves this model, or through the
    /// general path (`compute_forces`, then the update) with `None`. Both give the same bits;
    /// this is for the tests that say so and for measuring what each kernel is worth.
    pub fn set_simd(&mut self, kernel: Option<Simd>) {
        self.fused = kernel
            .filter(|_| FusedStep::serves(&self.model, self.integrator))
            .map(|k| FusedStep::new(&self.model, self.integrator, k));
    }

    /// Precondition implicit Euler's conjugate gradients with `p` from the next step on (by
    /// default `physics::preconditioner_of`): for the tests and benchmarks that compare them.
    pub fn set_preconditioner(&mut self, p: Preconditioner) {
        self.scratch.set_preconditioner(p);
    }

    /// What preconditions implicit Euler's conjugate gradients.
    pub fn preconditioner(&self) -> Preconditioner {
        self.scratch.preconditioner()
    }

    /// The fused step's kernel, `None` when the general path steps this model.
    pub fn simd(&self) -> Option<Simd> {
        self.fused.as_ref().map(FusedStep::simd)
    }

    /// Share of the masses the fused step computes in lanes, `None` without it.
    pub fn lane_share(&self) -> Option<f64> {
        self.fused.as_ref().map(FusedStep::run_share)
    }

    /// `advance` through the fused step: the state stays in its arrays for all `substeps`.
    fn advance_fused(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        let start = std::time::Instant::now();
        let Some(fused) = self.fused.as_mut() else {
            return Err(BackendError::Internal(Internal::FusedStepMissing));
        };
        let dt = f64::from(self.dt);
        fused.load(&self.state.x, &self.state.v);
        for _ in 0..substeps {
            if self.scratch.stop_asked() {
                break;
            }
            let (power, suspect) = fused.fused_step(&self.model, self.dt);
            self.state.ledger.accumulate(&power, dt);
            self.state.time_secs += dt;
            self.state.steps += 1;
            if suspect {
                fused.unload(&mut self.state.x, &mut self.state.v);
                if let Some(d) = find_divergence(&self.model, &self.state, self.integrator, dt) {
                    return Err(BackendError::Diverged(d));
                }
            }
        }
        fused.unload(&mut self.state.x, &mut self.state.v);
        Ok(StepStats {
            substeps,
            dt_secs: dt,
            step_ms: start.elapsed().as_secs_f64() * 1e3,
            ..StepStats::default()
        })
    }

    /// `advance` through the integrators' general steps.
    fn advance_general(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        let start = std::time::Instant::now();
        let (mut projections, mut deep_projections) = (0, 0);
        let mut solves = StepStats::default();
        for _ in 0..substeps {
            if self.scratch.stop_asked() {
                break;
            }
            if let Some(solve) = integrate::step(
                &self.model,
                self.integrator,
                &mut self.state,
                &mut self.scratch,
                self.dt,
            ) {
                solves = solves.merged(&StepStats {
                    solver_iterations: solve.iterations,
                    solver_residual: solve.residual,
                    newton_iterations: solve.newton,
                    rule: Some(RuleOutcome::of_step(solve.step_residual, solve.met)),
                    ..StepStats::default()
                });
            }
            // Verlet keeps a(x_n) from before a (rare) safeguard projection, as the GPU does,
            // which cannot know that one happened without a read-back.
            let projected = project_contacts(&self.model, &mut self.state);
            projections += projected.count;
            deep_projections += projected.deep;
            if self.model.effects.springs_change() {
                self.scratch.update_springs(&mut self.state);
            }
            if let Some(d) = find_divergence(
                &self.model,
                &self.state,
                self.integrator,
                f64::from(self.dt),
            ) {
                return Err(BackendError::Diverged(d));
            }
        }
        Ok(StepStats {
            substeps,
            dt_secs: f64::from(self.dt),
            step_ms: start.elapsed().as_secs_f64() * 1e3,
            projections,
            deep_projections,
            ..solves
        })
    }
}

impl Backend for CpuBackend {
    fn describe(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }

    fn watch(&mut self, flags: StopFlags) {
        self.scratch.watch(flags);
    }

    fn advance(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        let parallel = self.model.mass_count() >= PARALLEL_MIN_MASSES;
        let mut go = || {
            if self.fused.is_some() {
                self.advance_fused(substeps)
            } else {
                self.advance_general(substeps)
            }
        };
        // Below PARALLEL_MIN_MASSES every loop runs on this thread, and the trip to the pool
        // would cost an advance of one hair step 20–35% (BENCHMARKS.md, "The CPU's loops on
        // the pool, and the preconditioner by stiffness against the step").
        if parallel { in_pool(go) } else { go() }
    }

    fn request_snapshot(&mut self, frame: u64, stats: StepStats) -> Result<(), BackendError> {
        let t = self.state.time_secs;
        let mut snap = self.spare.pop().unwrap_or_else(|| Snapshot {
            stats,
            ..Snapshot::at(frame, t, 0)
        });
        snap.digest = None;
        snap.notes.clear();
        snap.frame = frame;
        snap.time_secs = t;
        snap.steps = self.state.steps;
        snap.stats = stats;
        snap.positions.clear();
        snap.positions.extend_from_slice(&self.state.x);
        let springs = self.scratch.springs();
        compute_strain(springs, &self.state.x, &mut snap.strain);
        snap.energies = compute_energies(&self.model, springs, &self.state);
        snap.collider_positions.clear();
        snap.collider_positions.extend(
            self.model
                .effects
                .colliders
                .iter()
                .map(|c| c.path.pose_at(t).position_m),
        );
        self.pending.push_back(snap);
        Ok(())
    }

    fn recycle(&mut self, snapshot: Snapshot) {
        if self.spare.len() < 8 {
            self.spare.push(snapshot);
        }
    }

    fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError> {
        Ok(self.pending.pop_front())
    }

    fn state(&mut self) -> Result<State, BackendError> {
        Ok(self.state.clone())
    }

    fn neighbour_builds(&mut self) -> Result<Option<u64>, BackendError> {
        Ok(self.scratch.neighbour_builds())
    }
}
