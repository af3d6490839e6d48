//! What one integrator is, as the rest of the program asks it: a [`Scheme`], one per scheme's
//! file in this folder. Every field is a decision a new scheme makes, and the struct literal
//! names each, so the compiler asks for all of them. The backends keep the tables of what
//! differs in code: the CPU's step (`cpu/integrate.rs`) and the GPU's passes (`gpu/plan.rs`,
//! `gpu/fused_plan.rs`).

use super::options::StepOptions;
use super::oscillator::{OneStep, Oscillator, radius_of_step};

/// One integrator's row of the table.
#[derive(Debug)]
pub struct Scheme {
    /// On the command line and in scene files.
    pub name: &'static str,
    /// In a sentence: "implicit Euler", "VBD".
    pub title: &'static str,
    /// Global order of accuracy: halving dt divides the error by `2^order`.
    pub order: u32,
    pub solve: Solve,
    pub stable_step: StableStep,
    /// Its effect on the test oscillator, whose spectral radius bounds the stable step.
    pub amplification: Amplification,
}

/// How a step is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Solve {
    /// In closed form from forces already known.
    Explicit(Explicit),
    /// Backward Euler's equations by Newton's method and conjugate gradients: the solver, its
    /// stopping rules and its statistics. `history`: the step starts from a blend of the last
    /// two states (BDF2), which a backend keeps.
    Newton { history: bool },
    /// A fixed number of Gauss–Seidel sweeps a step.
    Sweeps(Sweeps),
}

/// An explicit scheme's shape, as the fused steps see it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Explicit {
    /// One force evaluation and one update a step, so a fused step is one dispatch (forward
    /// Euler; `symplectic`: the position moves with the new velocity, semi-implicit Euler).
    OneUpdate { symplectic: bool },
    /// Stages, or an acceleration kept from the step before (RK2, RK4, Verlet).
    Staged,
}

/// A scheme of sweeps: over what, and how a user sets and is told about them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sweeps {
    pub over: Over,
    /// The command-line flag that sets them.
    pub flag: &'static str,
    /// What one count of sweeps serves: "step" or "substep".
    pub per: &'static str,
    /// What a user whose sweeps fall short could take instead.
    pub instead: &'static str,
    /// The name of the scheme whose step the forces it does not sweep (contacts and drag)
    /// take, where they are not in the system it sweeps: that scheme's stable step on them holds
    /// this one's too (`stability::estimate`).
    pub contacts_as: Option<&'static str>,
}

/// What a sweep visits in colour order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Over {
    /// Springs, each projected as a compliant constraint (XPBD).
    Springs,
    /// Masses, each a 3 × 3 block of backward Euler's system (VBD).
    Masses,
}

impl Sweeps {
    /// The run's sweeps, from its options.
    pub fn count(&self, options: &StepOptions) -> u32 {
        match self.over {
            Over::Springs => options.xpbd_iterations,
            Over::Masses => options.vbd_iterations,
        }
    }
}

/// How large a step the scheme survives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StableStep {
    /// Up to a limit set by the stiffest mode, found on the test oscillator.
    Limited,
    /// Any step on a spring; `why`, as `hooke check` says it, with what still bounds the step.
    Any { why: &'static str },
}

/// A scheme's effect on the test oscillator.
#[derive(Debug, Clone, Copy)]
pub enum Amplification {
    /// A one-step map, the scheme's step as the backends take it.
    Step(OneStep),
    /// The spectral radius itself, for a scheme with no one-step map (BDF2 takes two states).
    Radius(fn(&Oscillator) -> f64),
}

impl Scheme {
    /// Whether every step is stable on a spring: no stable step to estimate, and no substeps
    /// needed for stability.
    pub fn unconditionally_stable(&self) -> bool {
        match self.stable_step {
            StableStep::Limited => false,
            StableStep::Any { .. } => true,
        }
    }

    /// Whether a step is Newton's and conjugate gradients' (implicit Euler, BDF2).
    pub fn newton(&self) -> bool {
        match self.solve {
            Solve::Newton { .. } => true,
            Solve::Explicit(_) | Solve::Sweeps(_) => false,
        }
    }

    /// Whether a step starts from the last two states (BDF2).
    pub fn history(&self) -> bool {
        match self.solve {
            Solve::Newton { history } => history,
            Solve::Explicit(_) | Solve::Sweeps(_) => false,
        }
    }

    /// The scheme's sweeps, where it sweeps.
    pub fn sweeps(&self) -> Option<&Sweeps> {
        match &self.solve {
            Solve::Sweeps(s) => Some(s),
            Solve::Explicit(_) | Solve::Newton { .. } => None,
        }
    }

    /// An explicit scheme's shape.
    pub fn explicit(&self) -> Option<Explicit> {
        match self.solve {
            Solve::Explicit(e) => Some(e),
            Solve::Newton { .. } | Solve::Sweeps(_) => None,
        }
    }

    /// Whether a step assembles each mass's 3 × 3 block of backward Euler's system (implicit
    /// Euler, BDF2, VBD): the contacts' blocks with it, and no mass–mass contact, whose pairs
    /// have no block.
    pub fn assembles_blocks(&self) -> bool {
        match self.solve {
            Solve::Newton { .. } => true,
            Solve::Sweeps(s) => match s.over {
                Over::Masses => true,
                Over::Springs => false,
            },
            Solve::Explicit(_) => false,
        }
    }

    /// Spectral radius of one step on the test oscillator.
    pub fn amplification(&self, o: &Oscillator) -> f64 {
        match self.amplification {
            Amplification::Step(step) => radius_of_step(step, o),
            Amplification::Radius(radius) => radius(o),
        }
    }
}
