//! A state that went bad, described for the user: where, what, which stability limit the step
//! crossed there, and the step that would hold. The message is written once, in `Display`,
//! from the fields.

use std::fmt;

use crate::integrator::Integrator;
use crate::laws::spring_kind::SpringKindTag;
use crate::stability::{Limit, Source, StableStep};

/// What was wrong with the mass's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fault {
    NonFinite,
    Runaway { speed_m_per_s: f32 },
}

/// The spring at the diverged mass that is stretched or squeezed the most.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrainedSpring {
    pub index: u32,
    pub kind: SpringKindTag,
    /// (length − rest) / rest; infinite where it cannot be told (a zero rest length, a
    /// non-finite end).
    pub strain: f32,
    pub stiffness_n_per_m: f32,
}

/// The state stopped being finite or ran away. Carries what a user needs to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct Divergence {
    pub step: u64,
    pub time_secs: f64,
    pub mass: u32,
    pub fault: Fault,
    /// The mass's body and its index in that body's grid.
    pub body: Option<(String, u32)>,
    pub spring: Option<StrainedSpring>,
    pub dt_secs: f64,
    pub integrator: Integrator,
    /// The scene's estimated stable step for the integrator (`hooke check`'s).
    pub scene: StableStep,
    /// The estimate from the diverged mass's own springs and contacts: which limit binds there.
    pub here: StableStep,
}

impl fmt::Display for Divergence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "the simulation diverged at step {} (t = {:.6} s): ",
            self.step, self.time_secs
        )?;
        match self.fault {
            Fault::NonFinite => f.write_str("a non-finite position or velocity")?,
            Fault::Runaway { speed_m_per_s } => {
                write!(f, "a runaway speed of {speed_m_per_s:.3e} m/s")?
            }
        }
        write!(f, " at mass {}", self.mass)?;
        if let Some((name, local)) = &self.body {
            write!(f, " (body '{name}', mass {local} of its grid)")?;
        }
        if let Some(s) = &self.spring {
            write!(
                f,
                ", its most strained spring is {} ({}, strain {:.3e}, stiffness {} N/m)",
                s.index,
                s.kind.name(),
                s.strain,
                s.stiffness_n_per_m
            )?;
        }
        f.write_str(". ")?;
        self.verdict(f)
    }
}

impl Divergence {
    /// Which limit the step crossed and the step that would hold, or, where the step is within
    /// the estimate, that its size alone does not explain the divergence.
    fn verdict(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (dt, scheme) = (self.dt_secs, self.integrator);
        let limit_here = self.here.limit.or(self.scene.limit);
        match (self.scene.dt_secs, limit_here) {
            (None, limit) => {
                write!(
                    f,
                    "`{scheme}` is unstable at any practical dt on this scene"
                )?;
                if let Some(l) = limit {
                    write!(f, " ({l})")?;
                }
                if let Some(line) = self.scene.dashpot_line_secs {
                    write!(
                        f,
                        "; the dashpots along its springs allow at most dt ≤ {line:.3e} s, and \
                         dt = {dt:.3e} s: try a smaller --dt (--dt {:.3e})",
                        0.5 * dt.min(line)
                    )?;
                }
                f.write_str(
                    ", or use semi-implicit, verlet or rk4 (run `hooke check` for each integrator's stable step)",
                )
            }
            (Some(holds), limit) if dt > holds => {
                write!(
                    f,
                    "The step dt = {dt:.3e} s is too large for `{scheme}` here"
                )?;
                if let Some(l) = limit {
                    write!(f, ": it crossed the {} limit set by {l}", l.name())?;
                    if let Some(local) = self.here.finite_dt() {
                        write!(f, ", which holds it to dt ≤ {local:.3e} s at this mass")?;
                    }
                }
                write!(
                    f,
                    ". A step that holds on the whole scene: dt ≤ {holds:.3e} s; use a smaller \
                     --dt (--dt {holds:.3e}) or more --substeps (`hooke check` gives each \
                     integrator's stable step)"
                )
            }
            (Some(holds), _) => {
                write!(
                    f,
                    "The step dt = {dt:.3e} s is within the stable step estimated for `{scheme}` \
                     ({}), so its size alone does not explain this",
                    if holds.is_finite() {
                        format!("{holds:.3e} s")
                    } else {
                        "any step".to_owned()
                    }
                )?;
                if let Some(cause) = self.likely_cause() {
                    write!(f, ": {cause}")?;
                }
                write!(
                    f,
                    ". Try a smaller --dt (--dt {:.3e}) to see whether it holds, and run `hooke check`",
                    0.5 * dt.min(holds)
                )
            }
        }
    }

    fn likely_cause(&self) -> Option<&'static str> {
        if self.spring.is_some_and(|s| s.strain < -0.5) {
            return Some(
                "its most strained spring is squeezed below half its rest length, where a spring \
                 is stiffer sideways than its stiffness k, which the estimate assumes",
            );
        }
        // A scheme with no stable step on an undamped mode (forward Euler, RK2).
        if self.integrator.stable_dt(1.0, 0.0).is_none() {
            return Some(
                "this scheme needs damping in every mode, and a stretched spring's sideways swing \
                 has no dashpot (the estimate sees only the dashpots along the springs)",
            );
        }
        match self.here.limit {
            Some(Limit::Stiffness {
                source: Source::MassContact,
                ..
            }) => Some(
                "a mass pressed by several others at once is stiffer than the one contact \
                     pair the estimate counts",
            ),
            _ => None,
        }
    }
}

/// A run's solver stopped short of its own acceptance rule frame after frame: its results are
/// not the scheme's, so the run stops as it does for a divergence (`solver_watch`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{solver}'s steps ended short of their acceptance rule for {frames} frames in a row, to frame \
     {frame}: backward Euler's residual |h f − M Δv| was left at {residual:.3} of the step's \
     momentum change |h f|, where the rule asks for at most {tolerance:.3}. The results are not \
     {solver}'s. Try a smaller step (--dt, or more substeps), {instead}, or --backend cpu \
     (and report the adapter if the CPU converges)"
)]
pub struct Unconverged {
    /// The integrator's name.
    pub solver: &'static str,
    pub frame: u64,
    pub frames: u32,
    pub residual: f64,
    pub tolerance: f64,
    /// What else to try for this solver.
    pub instead: Remedy,
}

/// What else a solver stopped short may try.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Remedy {
    /// More of its sweeps, set by `flag`.
    MoreSweeps { flag: &'static str },
    /// The preconditioner it did not take.
    OtherPreconditioner,
}

impl std::fmt::Display for Remedy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Remedy::MoreSweeps { flag } => write!(f, "more sweeps ({flag})"),
            Remedy::OtherPreconditioner => {
                f.write_str("the other preconditioner (--preconditioner multigrid or block-jacobi)")
            }
        }
    }
}

/// The run went unphysical while its state stayed finite: an energy term no longer finite
/// (forces or energies past the range of the numbers that hold them: a gravity of 1e30 m/s²
/// held the masses on the ground and booked infinite contact work), a balance that rose by more
/// than all the energy the run held or moved, or an impact too fast for the step, which the
/// contact safeguard would resolve by flattening the body. The run stops as it does for a
/// divergence (`solver_watch`); the frame that showed it is not recorded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Unphysical {
    #[error(
        "the energy ledger went non-finite at frame {frame}: {term} is {value} while the state \
         stayed finite. Forces or energies have left the range they are held in: check the \
         scene's magnitudes (gravity, stiffnesses, masses, start speeds) for one far beyond \
         the physical"
    )]
    NonFinite {
        frame: u64,
        /// The recording's name for the term (`energy/...`).
        term: &'static str,
        value: f64,
    },
    #[error(
        "the energy balance rose by {gained_j:.4e} J to frame {frame}, more than the \
         {moved_j:.4e} J the run held or moved, for {frames} frames running: the integrator is \
         making energy, and the \
         results are not physics. Try a smaller step (--dt, or more substeps) or a more stable \
         integrator (implicit, bdf2)"
    )]
    EnergyRunaway {
        frame: u64,
        frames: u32,
        gained_j: f64,
        moved_j: f64,
    },
    #[error(
        "an impact in frame {frame} was too fast for the step: masses sank more than a grid \
         spacing into a collider within one step of {dt_secs:.3e} s ({masses} times in the \
         frame's steps){}, and the contact safeguard would flatten the body to put them back. {}",
        speed_m_per_s.map_or_else(String::new, |v| format!(" (the bodies moved at about {v:.3e} m/s)")),
        resolving_dt_secs.map_or_else(
            || "Use a smaller step (--dt), or a lower speed".to_owned(),
            |dt| format!(
                "A step of dt ≤ {dt:.3e} s (--dt {dt:.3e}) keeps each step's sink within the \
                 contact's depth; a body this fast may still be crushed where its springs \
                 cannot stop it, so a lower speed or stiffer springs may be what the scene needs"
            )
        )
    )]
    UnresolvedImpact {
        frame: u64,
        masses: u32,
        dt_secs: f64,
        /// The bodies' RMS speed before the impact, where they moved.
        speed_m_per_s: Option<f64>,
        /// The step at which a mass at that speed sinks, in one step, no deeper than the
        /// contact allows.
        resolving_dt_secs: Option<f64>,
    },
}
