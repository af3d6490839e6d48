//! The CPU reference backend: f32 like the GPU, multi-threaded with rayon, deterministic (every
//! mass is written by one task and every sum is taken over fixed chunks in a fixed order).

mod collide;
mod forces;
mod implicit;
mod integrate;
mod reduce;

pub use collide::project_contacts;
pub use forces::{Gather, PARALLEL_MIN_MASSES, compute_forces, contact_force, spring_force};
pub use implicit::{CG_MAX_ITERATIONS, CG_TOLERANCE, SolveStats};
pub use reduce::{compute_energies, compute_strain};

use crate::backend::{Backend, BackendError, find_divergence};
use crate::integrator::Integrator;
use crate::model::Model;
use crate::state::{Snapshot, State, StepStats};

pub struct CpuBackend {
    model: std::sync::Arc<Model>,
    integrator: Integrator,
    dt: f32,
    state: State,
    scratch: integrate::Scratch,
    pending: std::collections::VecDeque<Snapshot>,
}

impl CpuBackend {
    pub fn new(model: std::sync::Arc<Model>, integrator: Integrator, dt_secs: f64) -> Self {
        Self {
            state: model.initial.clone(),
            scratch: integrate::Scratch::new(&model),
            pending: std::collections::VecDeque::new(),
            model,
            integrator,
            dt: dt_secs as f32,
        }
    }
}

impl Backend for CpuBackend {
    fn describe(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }

    fn advance(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        let start = std::time::Instant::now();
        let mut projections = 0;
        let (mut iterations, mut residual) = (0u32, 0.0f64);
        for _ in 0..substeps {
            if let Some(solve) = integrate::step(
                &self.model,
                self.integrator,
                &mut self.state,
                &mut self.scratch,
                self.dt,
            ) {
                iterations = iterations.max(solve.iterations);
                residual = residual.max(solve.residual);
            }
            // Verlet keeps a(x_n) from before a (rare) safeguard projection, as the GPU does,
            // which cannot know that one happened without a read-back.
            projections += project_contacts(&self.model, &mut self.state);
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
            solver_iterations: iterations,
            solver_residual: residual,
        })
    }

    fn request_snapshot(&mut self, frame: u64, stats: StepStats) -> Result<(), BackendError> {
        let mut strain = Vec::with_capacity(self.model.spring_count());
        compute_strain(&self.model, &self.state.x, &mut strain);
        self.pending.push_back(Snapshot {
            frame,
            time_secs: self.state.time_secs,
            steps: self.state.steps,
            positions: self.state.x.clone(),
            strain,
            energies: compute_energies(&self.model, &self.state),
            stats,
            sphere_centers: self
                .model
                .effects
                .spheres
                .iter()
                .map(|s| s.center_at(self.state.time_secs))
                .collect(),
        });
        Ok(())
    }

    fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError> {
        Ok(self.pending.pop_front())
    }

    fn state(&mut self) -> Result<State, BackendError> {
        Ok(self.state.clone())
    }
}
