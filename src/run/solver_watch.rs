//! The run's watch on what its solver and its energy ledger say, frame by frame, on the
//! simulation thread, whichever backend steps: a frame whose implicit Euler, BDF2 or VBD steps
//! ended short of their acceptance rule is said once (`FrameNote::SolverShort`), and
//! `STUCK_FRAMES` frames in a row whose steps leave more than `STUCK_RESIDUAL` of backward
//! Euler's equations unmet stop the run as a divergence does (`divergence::Unconverged`); a
//! balance that rises beyond `GAIN_SHARE` of the energy that moved is said once
//! (`FrameNote::EnergyGained`). One that stays past all the energy the run held or moved for
//! `RUNAWAY_FRAMES` frames, a ledger term that is no longer finite, or an impact the step cannot
//! resolve (`StepStats::deep_projections`) stops the run (`divergence::Unphysical`). A driver
//! that computes the wrong thing shows up here even where no test has run on it.
//!
//! Measured on the built-in scenes on the CPU (60 frames each, BENCHMARKS.md, "Solvers report
//! what they did"): implicit Euler and BDF2 end some steps short of their rule where contacts
//! start or stop (cloth onto its sphere at 1/60 s: 19 frames of 60, the worst at 0.32 of |h f|
//! against 0.03), while a frame's typical step meets it; VBD at one step per frame with its
//! default sweeps leaves 0.89–0.98 of the residual, which `check` and the run's start already
//! warn of (`stability::sweep_warning`).

use crate::backend::{Backend, BackendError, Then};
use crate::integrator::{Integrator, Over, Solve};
use crate::model::Model;
use crate::physics::{VBD_RESIDUAL, newton_residual};
use crate::scene::settings::Settings;
use crate::stability::divergence::{Remedy, Unconverged, Unphysical};
use crate::stability::sweep_shortfall;
use crate::state::{FrameNote, Snapshot};

/// Frames in a row whose steps end short of their rule, leaving more than `STUCK_RESIDUAL`,
/// before the run stops: half a second at 60 frames a second. A hard frame or two (an impact, a collider's sudden turn) is said and
/// passes; a solver that cannot meet its rule at this step on this scene, or a device that
/// computes it wrongly, does not.
pub const STUCK_FRAMES: u32 = 30;

/// The residual |h f − M Δv| / |h f| above which a frame counts towards stopping the run: half
/// the step's momentum change unexplained. Newton's rule asks for 3% at one step per frame, and
/// the survey above saw no frame of a default Newton run stay above this for two frames running.
pub const STUCK_RESIDUAL: f64 = 0.5;

/// The share of the energy that moved (the most kinetic energy seen, plus what was dissipated
/// and what colliders did) by which the balance may rise before the run says energy came from
/// nowhere. Numerical damping lowers the balance, and is the scheme's known cost (`bench
/// accuracy` measures it); a rise is never physical.
pub const GAIN_SHARE: f64 = 0.1;

/// The share of the energy that moved (or that the run held at its start, if more) by which a
/// rise of the balance stops the run: more energy made than the run ever held or moved is no
/// longer a scheme's drift.
pub const RUNAWAY_SHARE: f64 = 1.0;

/// Frames in a row the balance must stay past `RUNAWAY_SHARE` before the run stops: a sixth of
/// a second at 60 frames a second.
pub const RUNAWAY_FRAMES: u32 = 10;

/// What the watch keeps between frames.
#[derive(Debug)]
pub struct SolverWatch {
    integrator: Integrator,
    /// The acceptance rule's most |h f − M Δv| / |h f| (`None`: no solver to watch).
    tolerance: Option<f64>,
    /// Whether a stuck solver stops the run: not VBD whose sweeps are known to fall short at
    /// this step (the run has said so as it began).
    may_stop: bool,
    short_in_a_row: u32,
    said_short: bool,
    start_balance_j: Option<f64>,
    most_kinetic_j: f64,
    /// The movable masses' total, the RMS speed of the last frame, and the least depth a
    /// contact allows before the safeguard projects (none without contacts).
    movable_kg: f64,
    last_speed_m_per_s: f64,
    allowed_depth_m: Option<f64>,
    said_gain: bool,
    runaway_in_a_row: u32,
}

impl SolverWatch {
    /// The watch for a run of `model` as `settings` say.
    pub fn new(model: &Model, settings: &Settings) -> Self {
        let step = settings.step();
        let scheme = step.integrator.scheme();
        // A rule to meet: Newton's, or VBD's residual. XPBD's sweeps and the explicit schemes
        // have none.
        let tolerance = match scheme.solve {
            Solve::Newton { .. } => Some(newton_residual(step.dt_secs, scheme.order)),
            Solve::Sweeps(s) => match s.over {
                Over::Masses => Some(VBD_RESIDUAL),
                Over::Springs => None,
            },
            Solve::Explicit(_) => None,
        };
        // Sweeps that `check` already said fall short are not a stuck solver.
        let may_stop = scheme.sweeps().is_none() || sweep_shortfall(model, settings).is_none();
        Self {
            integrator: step.integrator,
            tolerance,
            may_stop,
            short_in_a_row: 0,
            said_short: false,
            start_balance_j: None,
            most_kinetic_j: 0.0,
            movable_kg: (0..model.mass_count())
                .filter(|&i| model.inv_mass[i] != 0.0)
                .map(|i| f64::from(model.mass_kg[i]))
                .sum(),
            last_speed_m_per_s: 0.0,
            allowed_depth_m: model
                .effects
                .ground
                .iter()
                .map(|g| g.max_depth_m)
                .chain(model.effects.colliders.iter().map(|c| c.max_depth_m))
                .map(f64::from)
                .reduce(f64::min),
            said_gain: false,
            runaway_in_a_row: 0,
        }
    }

    /// Look at one frame: notes go onto it; a solver stuck short of its rule, a ledger gone
    /// wrong or an impact the step cannot resolve stops the run.
    pub fn frame(&mut self, snap: &mut Snapshot) -> Result<(), BackendError> {
        self.solver(snap)
            .map_err(|u| BackendError::Unconverged(Box::new(u)))?;
        // A ledger gone non-finite says more than the impact it may have come with.
        let watched = self.energy(snap).and_then(|()| self.impact(snap));
        self.last_speed_m_per_s = self.rms_speed(snap);
        watched.map_err(|l| BackendError::Unphysical(Box::new(l)))
    }

    /// The movable masses' RMS speed in `snap`, from its kinetic energy.
    fn rms_speed(&self, snap: &Snapshot) -> f64 {
        match self.movable_kg > 0.0 {
            true => (2.0 * snap.energies.kinetic_j.max(0.0) / self.movable_kg).sqrt(),
            false => 0.0,
        }
    }

    /// A frame where masses sank past a whole grid spacing in one step stops the run: the
    /// safeguard that puts them back flattens the body (`cpu::Projected::deep`).
    fn impact(&self, snap: &Snapshot) -> Result<(), Unphysical> {
        let masses = snap.stats.deep_projections;
        if masses == 0 {
            return Ok(());
        }
        let speed = self.last_speed_m_per_s.max(self.rms_speed(snap));
        let speed_m_per_s = (speed > 0.0 && speed.is_finite()).then_some(speed);
        Err(Unphysical::UnresolvedImpact {
            frame: snap.frame,
            masses,
            dt_secs: snap.stats.dt_secs,
            speed_m_per_s,
            // A speed gained within the frame (a huge force) makes no estimate of the step.
            resolving_dt_secs: speed_m_per_s
                .zip(self.allowed_depth_m)
                .map(|(v, d)| d / v)
                .filter(|&dt| dt < snap.stats.dt_secs),
        })
    }

    fn solver(&mut self, snap: &mut Snapshot) -> Result<(), Unconverged> {
        let Some(tolerance) = self.tolerance else {
            return Ok(());
        };
        let s = snap.stats;
        let Some(rule) = s.rule else {
            return Ok(());
        };
        if rule.unmet_steps == 0 {
            self.short_in_a_row = 0;
            return Ok(());
        }
        if rule.step_residual > STUCK_RESIDUAL {
            self.short_in_a_row += 1;
        } else {
            self.short_in_a_row = 0;
        }
        if !self.said_short {
            self.said_short = true;
            snap.notes.push(FrameNote::SolverShort {
                solver: self.integrator.name(),
                frame: snap.frame,
                unmet_steps: rule.unmet_steps,
                substeps: s.substeps,
                residual: rule.step_residual,
                tolerance,
                stops_if_it_lasts: self.may_stop,
            });
        }
        if self.short_in_a_row < STUCK_FRAMES || !self.may_stop {
            return Ok(());
        }
        Err(Unconverged {
            solver: self.integrator.name(),
            frame: snap.frame,
            frames: self.short_in_a_row,
            residual: rule.step_residual,
            tolerance,
            instead: match self.integrator.scheme().sweeps() {
                Some(s) => Remedy::MoreSweeps { flag: s.flag },
                None => Remedy::OtherPreconditioner,
            },
        })
    }

    fn energy(&mut self, snap: &mut Snapshot) -> Result<(), Unphysical> {
        let e = &snap.energies;
        // A non-finite state is the divergence check's to report (with the mass and spring);
        // a ledger that breaks while the state holds is this watch's.
        let state_finite = snap.positions.iter().all(|p| p.is_finite());
        if let Some((term, value)) = e.first_non_finite().filter(|_| state_finite) {
            return Err(Unphysical::NonFinite {
                frame: snap.frame,
                term,
                value,
            });
        }
        let balance = e.balance_j();
        let start = *self.start_balance_j.get_or_insert(balance);
        self.most_kinetic_j = self.most_kinetic_j.max(e.kinetic_j);
        let moved = self.most_kinetic_j + e.ledger.dissipated_j() + e.ledger.collider_work_j.abs();
        let gained = balance - start;
        // Against the energy the run held at its start as well, and for RUNAWAY_FRAMES frames in
        // a row: a symplectic scheme's energy swings about its shadow's (early in a run, before
        // much has moved, the swing can exceed what moved), while a scheme making energy keeps
        // gaining; one that grows fast diverges first, and the divergence check names the mass.
        let runaway = gained.is_finite() && gained > RUNAWAY_SHARE * moved.max(start.abs());
        self.runaway_in_a_row = if runaway {
            self.runaway_in_a_row + 1
        } else {
            0
        };
        if !gained.is_finite() || gained <= GAIN_SHARE * moved || gained <= 0.0 {
            return Ok(());
        }
        if self.runaway_in_a_row >= RUNAWAY_FRAMES {
            return Err(Unphysical::EnergyRunaway {
                frame: snap.frame,
                frames: self.runaway_in_a_row,
                gained_j: gained,
                moved_j: moved.max(start.abs()),
            });
        }
        if !self.said_gain {
            self.said_gain = true;
            snap.notes.push(FrameNote::EnergyGained {
                frame: snap.frame,
                gained_j: gained,
                moved_j: moved,
                share: GAIN_SHARE,
            });
        }
        Ok(())
    }
}

/// `inner` with its snapshots watched by `watch` as they are collected.
pub fn watching(inner: Box<dyn Backend>, mut watch: SolverWatch) -> Box<dyn Backend> {
    Box::new(Then::new(inner, move |s: &mut Snapshot| watch.frame(s)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::{Energies, StepStats};

    /// The watch of a pendulum (one mass on a spring from a pin) run with `integrator` at `dt`.
    fn watch(integrator: Integrator, dt: f64) -> SolverWatch {
        let mut mb = crate::model::ModelBuilder::new();
        let pin = mb.mass(glam::Vec3::ZERO, glam::Vec3::ZERO, 1.0, true);
        let bob = mb.mass(glam::Vec3::X, glam::Vec3::ZERO, 1.0, false);
        mb.spring(pin, bob, 100.0, 0.1);
        let settings = Settings {
            integrator,
            frame_rate_hz: 60.0,
            substeps: 1,
            dt_secs: dt,
            frames: 60,
            options: Default::default(),
            notes: Vec::new(),
        };
        SolverWatch::new(&mb.build(), &settings)
    }

    fn frame(frame: u64, unmet_steps: u32, kinetic_j: f64) -> Snapshot {
        Snapshot {
            energies: Energies {
                kinetic_j,
                ..Energies::default()
            },
            stats: StepStats {
                substeps: 2,
                rule: Some(crate::state::RuleOutcome {
                    step_residual: 0.6,
                    unmet_steps,
                }),
                ..StepStats::default()
            },
            ..Snapshot::at(frame, 0.0, frame)
        }
    }

    /// A short frame is said once; the run stops at the STUCK_FRAMES-th short frame in a row,
    /// and a frame that meets the rule starts the count again.
    #[test]
    fn a_solver_short_of_its_rule_is_said_once_and_stops_the_run_when_it_lasts() {
        let mut w = watch(Integrator::Implicit, 1.0 / 60.0);
        let mut f = frame(1, 1, 0.0);
        assert!(w.frame(&mut f).is_ok());
        assert!(matches!(
            f.notes[..],
            [FrameNote::SolverShort { frame: 1, .. }]
        ));
        let mut g = frame(2, 0, 0.0);
        assert!(w.frame(&mut g).is_ok() && g.notes.is_empty());
        for k in 0..STUCK_FRAMES - 1 {
            let mut f = frame(3 + u64::from(k), 2, 0.0);
            assert!(w.frame(&mut f).is_ok(), "frame {}", f.frame);
            assert!(f.notes.is_empty());
        }
        let stuck = w.frame(&mut frame(100, 2, 0.0));
        let Err(BackendError::Unconverged(e)) = stuck else {
            panic!("not stopped: {stuck:?}");
        };
        assert_eq!((e.frame, e.frames), (100, STUCK_FRAMES));
        let said = e.to_string();
        assert!(
            said.contains("implicit") && said.contains("frame 100"),
            "{said}"
        );
        assert!(
            said.contains("--backend cpu") && said.contains("--dt"),
            "{said}"
        );
        // Explicit integrators have no rule to watch.
        let mut w = watch(Integrator::SemiImplicit, 1e-4);
        for k in 0..2 * STUCK_FRAMES {
            assert!(w.frame(&mut frame(u64::from(k), 1, 0.0)).is_ok());
        }
    }

    /// Energy from nowhere is said once, at the frame where the balance first rises past
    /// GAIN_SHARE of what moved; a fall (numerical damping) is not.
    #[test]
    fn a_balance_that_rises_past_its_share_of_what_moved_is_said_once() {
        let mut w = watch(Integrator::SemiImplicit, 1e-4);
        // 10 J of kinetic energy from 10 J of potential: balanced.
        let mut start = frame(0, 0, 0.0);
        start.energies.gravity_j = 10.0;
        assert!(w.frame(&mut start).is_ok() && start.notes.is_empty());
        let mut falling = frame(1, 0, 10.0);
        assert!(w.frame(&mut falling).is_ok() && falling.notes.is_empty());
        let mut damped = frame(2, 0, 5.0);
        assert!(w.frame(&mut damped).is_ok() && damped.notes.is_empty());
        // 1.5 J more than was ever there (10 J moved).
        let mut gained = frame(3, 0, 1.5);
        gained.energies.gravity_j = 10.0;
        assert!(w.frame(&mut gained).is_ok());
        assert!(
            matches!(gained.notes[..], [FrameNote::EnergyGained { frame: 3, .. }]),
            "{:?}",
            gained.notes
        );
        let mut again = frame(4, 0, 3.0);
        again.energies.gravity_j = 10.0;
        assert!(w.frame(&mut again).is_ok() && again.notes.is_empty());
    }

    /// A ledger term that is no longer finite while the state is stops the run, naming the
    /// term; so does a balance that rises by more than all the energy the run held or moved. A non-finite
    /// state is left to the divergence check, which names the mass.
    #[test]
    fn a_broken_ledger_stops_the_run_naming_what_broke() {
        let mut w = watch(Integrator::SemiImplicit, 1e-4);
        let mut start = frame(0, 0, 0.0);
        start.positions = vec![glam::Vec3::ZERO];
        assert!(w.frame(&mut start).is_ok());
        let mut inf = frame(1, 0, 1.0);
        inf.positions = vec![glam::Vec3::ZERO];
        inf.energies.ledger.contact_j = f64::INFINITY;
        let Err(BackendError::Unphysical(e)) = w.frame(&mut inf) else {
            panic!("not stopped");
        };
        assert!(
            matches!(
                *e,
                Unphysical::NonFinite {
                    frame: 1,
                    term: "energy/dissipated_contact",
                    ..
                }
            ),
            "{e}"
        );
        inf.positions = vec![glam::Vec3::NAN];
        assert!(w.frame(&mut inf).is_ok());
        // 10 J moved; the balance rises by 5 J (said), then by 30 J held in the springs while
        // at most 15 J ever moved, for RUNAWAY_FRAMES frames (stopped at the last).
        let mut w = watch(Integrator::SemiImplicit, 1e-4);
        let mut start = frame(0, 0, 0.0);
        start.energies.gravity_j = 10.0;
        assert!(w.frame(&mut start).is_ok());
        assert!(w.frame(&mut frame(1, 0, 10.0)).is_ok());
        let mut said = frame(2, 0, 15.0);
        assert!(w.frame(&mut said).is_ok() && said.notes.len() == 1);
        let runaway = |frame_no: u64| {
            let mut f = frame(frame_no, 0, 5.0);
            f.energies.elastic_j = 35.0;
            f
        };
        for k in 0..RUNAWAY_FRAMES - 1 {
            assert!(w.frame(&mut runaway(3 + u64::from(k))).is_ok(), "{k}");
        }
        let last = 3 + u64::from(RUNAWAY_FRAMES) - 1;
        let Err(BackendError::Unphysical(e)) = w.frame(&mut runaway(last)) else {
            panic!("not stopped");
        };
        assert!(
            matches!(*e, Unphysical::EnergyRunaway { frame, .. } if frame == last),
            "{e}"
        );
    }
}
