//! The GPU backend's snapshots: a frame's read-back submitted behind the next frame's steps,
//! finished into a `Snapshot` (energies, strain, the solver's figures), and the first bad state
//! found in it.

use super::backend::GpuBackend;
use super::context::ReadBackOf;
use super::encode::in_pass;
use super::readback::{self, Decode, Pending, ReadBack, Reductions, SolveRecord, StagingLayout};
use crate::backend::{BackendError, Internal, RUNAWAY_SPEED_M_PER_S, find_divergence};
use crate::integrator::{Over, Solve};
use crate::stability::divergence::Divergence;
use crate::state::{Energies, Snapshot, State, StepStats};

impl GpuBackend {
    pub(super) fn staging_layout(&self) -> StagingLayout {
        StagingLayout::new(
            self.model.mass_count(),
            self.model.spring_count(),
            self.resources.workgroups.partial_count(),
        )
    }

    /// Run the reductions and copy what a snapshot needs (and `with_velocity`, the velocities) to a
    /// free staging buffer, without waiting: returns which buffer and the submission to wait for.
    pub(super) fn submit_read_back(
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
        let which = Reductions {
            strain: self.model.spring_count() > 0,
            released: e.springs_change(),
            pairs: e.self_collision.map(|_| self.list_build()),
        };
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
    pub(super) fn finish_read_back(
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
            let read = Decode {
                with_velocity,
                tearing: self.model.effects.tearing,
            };
            readback::decode(&data, self.staging_layout(), read, buffers)
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
    pub(super) fn divergence(&mut self, rb: &ReadBack, frame: &Pending) -> Option<Box<Divergence>> {
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
    pub(super) fn state_now(&mut self) -> Result<State, BackendError> {
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
    pub(super) fn with_solve(&self, stats: StepStats, solve: SolveRecord) -> StepStats {
        match self.integrator.scheme().solve {
            Solve::Newton { .. } => StepStats {
                solver_iterations: solve.cg_iterations,
                solver_residual: f64::from(solve.cg_residual),
                newton_iterations: solve.newton_iterations,
                rule: Some(solve.rule()),
                ..stats
            },
            Solve::Sweeps(s) => match s.over {
                Over::Masses => StepStats {
                    solver_iterations: self.resources.sweeps().iterations,
                    solver_residual: f64::from(solve.step_residual),
                    rule: Some(solve.rule()),
                    ..stats
                },
                Over::Springs => stats,
            },
            Solve::Explicit(_) => stats,
        }
    }

    pub(super) fn snapshot_of(
        &self,
        p: &Pending,
        rb: ReadBack,
        spare: Option<Snapshot>,
    ) -> Snapshot {
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
