//! What changes over time: the state a backend advances, the energy ledger, and the snapshots the
//! simulation thread sends to the recorder.

use glam::Vec3;

/// Energy that left (or entered) the system through non-conservative forces, integrated alongside
/// the state by the same integrator, so that `total + dissipated − collider work` is a check on the
/// integration itself.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Ledger {
    /// Spring damping, J.
    pub damping_j: f64,
    /// Air drag, J.
    pub drag_j: f64,
    /// Contact damping, friction and the post-step safeguard, J.
    pub contact_j: f64,
    /// Work done on the system by moving colliders, J.
    pub collider_work_j: f64,
    /// Elastic energy let go by plastic flow and by springs that broke, J.
    pub plastic_j: f64,
}

/// Rates of the ledger's entries at one state (W). Combined by the integrators like derivatives.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Power {
    pub damping_w: f64,
    pub drag_w: f64,
    pub contact_w: f64,
    pub collider_w: f64,
}

impl Power {
    pub fn add_scaled(&mut self, other: &Power, s: f64) {
        self.damping_w += s * other.damping_w;
        self.drag_w += s * other.drag_w;
        self.contact_w += s * other.contact_w;
        self.collider_w += s * other.collider_w;
    }
}

impl Ledger {
    pub fn accumulate(&mut self, p: &Power, dt: f64) {
        self.damping_j += dt * p.damping_w;
        self.drag_j += dt * p.drag_w;
        self.contact_j += dt * p.contact_w;
        self.collider_work_j += dt * p.collider_w;
    }
    pub fn dissipated_j(&self) -> f64 {
        self.damping_j + self.drag_j + self.contact_j + self.plastic_j
    }
}

/// Positions and velocities of every mass, the time, and the ledger.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    pub x: Vec<Vec3>,
    pub v: Vec<Vec3>,
    pub time_secs: f64,
    pub steps: u64,
    pub ledger: Ledger,
}

impl State {
    pub fn new(x: Vec<Vec3>, v: Vec<Vec3>) -> Self {
        Self {
            x,
            v,
            time_secs: 0.0,
            steps: 0,
            ledger: Ledger::default(),
        }
    }

    /// A hash (64-bit FNV-1a) of the positions' and velocities' bits: equal exactly when every
    /// bit of the state is, so a deterministic backend gives the same digest on every run.
    pub fn digest(&self) -> u64 {
        fnv1a(
            self.x
                .iter()
                .chain(&self.v)
                .flat_map(|p| p.to_array())
                .flat_map(|c| c.to_bits().to_le_bytes()),
        )
    }
}

/// 64-bit FNV-1a of `bytes`: the state's digest, and the names a sweep gives its plan and
/// references.
pub fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The energies of one snapshot (J).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energies {
    pub kinetic_j: f64,
    /// Springs' elastic energy.
    pub elastic_j: f64,
    /// Gravitational potential, zero at y = 0 for g along −y (in general −m g·x).
    pub gravity_j: f64,
    /// Energy stored in compressed contact penalty springs.
    pub contact_j: f64,
    pub ledger: Ledger,
}

impl Energies {
    /// Mechanical energy held by the system.
    pub fn total_j(&self) -> f64 {
        self.kinetic_j + self.elastic_j + self.gravity_j + self.contact_j
    }
    /// Constant in exact arithmetic: mechanical energy plus what was dissipated, less what
    /// moving colliders put in.
    pub fn balance_j(&self) -> f64 {
        self.total_j() + self.ledger.dissipated_j() - self.ledger.collider_work_j
    }

    /// The first term, by the recording's name for it, that is not finite.
    pub fn first_non_finite(&self) -> Option<(&'static str, f64)> {
        let l = &self.ledger;
        [
            ("energy/kinetic", self.kinetic_j),
            ("energy/elastic", self.elastic_j),
            ("energy/gravity", self.gravity_j),
            ("energy/contact", self.contact_j),
            ("energy/dissipated_damping", l.damping_j),
            ("energy/dissipated_drag", l.drag_j),
            ("energy/dissipated_contact", l.contact_j),
            ("energy/dissipated_plastic", l.plastic_j),
            ("energy/collider_work", l.collider_work_j),
        ]
        .into_iter()
        .find(|(_, v)| !v.is_finite())
    }
}

/// Per-frame stepping statistics.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepStats {
    pub substeps: u32,
    pub dt_secs: f64,
    /// Wall time spent stepping this frame.
    pub step_ms: f64,
    /// Masses the post-step safeguard pushed back out of a collider this frame.
    pub projections: u32,
    /// Of those, masses that had sunk past a whole grid spacing within a step: an impact the
    /// step cannot resolve (`cpu::Projected::deep`).
    pub deep_projections: u32,
    /// Implicit integrator: most conjugate-gradient iterations a step of this frame took.
    pub solver_iterations: u32,
    /// Implicit Euler: the largest final residual of a step's linear solves this frame, each
    /// relative to the Newton residual it started from (at most `CG_FORCING` when they
    /// converged). VBD on the CPU: its largest step residual |h f − M Δv| / |h f|.
    pub solver_residual: f64,
    /// Implicit Euler and BDF2: most Newton iterations a step of this frame took (a halved
    /// update counts as one: `physics::NEWTON_BACKTRACKS`).
    pub newton_iterations: u32,
    /// How the frame's steps met their solver's acceptance rule, where the backend judged
    /// them: implicit Euler, BDF2 and VBD on both backends; `None` elsewhere, never a made-up
    /// zero.
    pub rule: Option<RuleOutcome>,
}

/// How a frame's steps met their solver's acceptance rule (`physics::solver`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RuleOutcome {
    /// The largest residual of backward Euler's equations a step ended with, |h f − M Δv| /
    /// |h f| at its last iterate evaluated (Newton's before its last update, where that update
    /// ended it; for a Newton step short of its rule, at the best iterate it solved from, where
    /// it ended).
    pub step_residual: f64,
    /// Steps that ended without meeting the rule: Newton out of iterations short of its
    /// tolerance, VBD's sweeps short of `physics::VBD_RESIDUAL`.
    pub unmet_steps: u32,
}

impl RuleOutcome {
    /// One step's outcome: its residual, and whether it met the rule.
    pub fn of_step(step_residual: f64, met: bool) -> Self {
        Self {
            step_residual,
            unmet_steps: u32::from(!met),
        }
    }

    /// `a` followed by `b`, either of which may be unjudged.
    pub fn merged(a: Option<Self>, b: Option<Self>) -> Option<Self> {
        match (a, b) {
            (Some(a), Some(b)) => Some(Self {
                step_residual: a.step_residual.max(b.step_residual),
                unmet_steps: a.unmet_steps + b.unmet_steps,
            }),
            (a, b) => a.or(b),
        }
    }
}

impl StepStats {
    /// The statistics of `self` followed by `later` (two chunks of one frame).
    pub fn merged(&self, later: &StepStats) -> StepStats {
        StepStats {
            substeps: self.substeps + later.substeps,
            dt_secs: later.dt_secs,
            step_ms: self.step_ms + later.step_ms,
            projections: self.projections + later.projections,
            deep_projections: self.deep_projections + later.deep_projections,
            solver_iterations: self.solver_iterations.max(later.solver_iterations),
            solver_residual: self.solver_residual.max(later.solver_residual),
            newton_iterations: self.newton_iterations.max(later.newton_iterations),
            rule: RuleOutcome::merged(self.rule, later.rule),
        }
    }
}

/// One frame as the recorder sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    pub frame: u64,
    pub time_secs: f64,
    pub steps: u64,
    pub positions: Vec<Vec3>,
    /// (|x| − L) / L per spring; NaN for a broken spring.
    pub strain: Vec<f32>,
    pub energies: Energies,
    pub stats: StepStats,
    /// Collider positions (`model.effects.colliders` order) at this time.
    pub collider_positions: Vec<Vec3>,
    /// What the recorder reads from every spring, when a stage before it (on the simulation
    /// thread) has made it from these strains; `None`: the recorder makes it.
    pub digest: Option<Box<StrainDigest>>,
    /// What the run's watch says at this frame (`solver_watch`), each said once in a run.
    pub notes: Vec<FrameNote>,
}

/// A warning the run's watch attaches to the frame where it first holds: the recorder logs it
/// on the timeline (`notes`) and the run prints it.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameNote {
    /// Steps of the frame ended short of their solver's acceptance rule.
    SolverShort {
        /// The integrator's name.
        solver: &'static str,
        frame: u64,
        unmet_steps: u32,
        substeps: u32,
        /// The largest |h f − M Δv| / |h f| a step ended with, and the rule's most.
        residual: f64,
        tolerance: f64,
        /// Whether the run stops if it lasts (`solver_watch::STUCK_FRAMES`); not for VBD's
        /// sweeps already said to fall short before the run.
        stops_if_it_lasts: bool,
    },
    /// The energy balance rose by more than `share` of the energy that moved since the start:
    /// energy came from nowhere.
    EnergyGained {
        frame: u64,
        gained_j: f64,
        moved_j: f64,
        share: f64,
    },
}

impl std::fmt::Display for FrameNote {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FrameNote::SolverShort {
                solver,
                frame,
                unmet_steps,
                substeps,
                residual,
                tolerance,
                stops_if_it_lasts,
            } => write!(
                f,
                "warning: frame {frame}: {unmet_steps} of {substeps} {solver} steps ended short \
                 of their acceptance rule (residual |h f − M Δv| at {residual:.3} of |h f|, {}); \
                 {}stats/unmet_steps shows each frame's count",
                // BDF2's rule also asks that the residual do no work on the step's velocities
                // (physics::NEWTON_WORK_SHARE): a step can be short of it within the tolerance.
                match *solver == "bdf2" && residual <= tolerance {
                    true => format!(
                        "within the rule's {tolerance:.3} but doing more work on the velocities \
                         than BDF2's rule allows"
                    ),
                    false => format!("the rule asks for at most {tolerance:.3}"),
                },
                match stops_if_it_lasts {
                    true => "the run stops if this lasts, and ",
                    false => "",
                }
            ),
            FrameNote::EnergyGained {
                frame,
                gained_j,
                moved_j,
                share,
            } => write!(
                f,
                "warning: frame {frame}: the energy balance rose by {gained_j:.4e} J, more than \
                 {:.0}% of the {moved_j:.4e} J that moved: energy came from nowhere (see \
                 energy/balance); a smaller step or another integrator holds it",
                100.0 * share
            ),
        }
    }
}

/// The reductions over every spring of a frame that the recorder draws from: made beside the
/// simulation, the recorder's own work per frame does not grow with the springs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StrainDigest {
    /// The most strained intact spring and its strain.
    pub most: Option<(usize, f32)>,
    /// The strain histogram's bars.
    pub histogram: Vec<u64>,
    /// Per body (model order), each vertex's strain on a reduced surface; empty for the others.
    pub surfaces: Vec<Vec<f32>>,
}

impl Snapshot {
    /// Frame `frame` at `time_secs` after `steps` steps, with nothing in it yet: the start of
    /// every snapshot a backend, a benchmark or a test makes (`Snapshot { positions, ..at(…) }`).
    pub fn at(frame: u64, time_secs: f64, steps: u64) -> Self {
        Snapshot {
            frame,
            time_secs,
            steps,
            positions: Vec::new(),
            strain: Vec::new(),
            energies: Energies::default(),
            stats: StepStats::default(),
            collider_positions: Vec::new(),
            digest: None,
            notes: Vec::new(),
        }
    }

    /// Largest |strain| of the intact springs.
    pub fn max_abs_strain(&self) -> f32 {
        self.strain
            .iter()
            .filter(|s| !s.is_nan())
            .fold(0.0f32, |m, s| m.max(s.abs()))
    }
    /// Springs broken so far (tearing).
    pub fn broken_springs(&self) -> usize {
        self.strain.iter().filter(|s| s.is_nan()).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A BDF2 step short of its rule within the tolerance was short of the rule's other half,
    /// the residual's work on the velocities; the warning says which.
    #[test]
    fn a_step_short_of_its_rule_says_which_part_it_missed() {
        let short = |solver, residual| {
            FrameNote::SolverShort {
                solver,
                frame: 1,
                unmet_steps: 1,
                substeps: 1,
                residual,
                tolerance: 0.03,
                stops_if_it_lasts: true,
            }
            .to_string()
        };
        assert!(short("bdf2", 0.02).contains("within the rule's 0.030 but doing more work"));
        assert!(short("bdf2", 0.2).contains("at 0.200 of |h f|, the rule asks for at most 0.030"));
        assert!(short("implicit", 0.02).contains("the rule asks for at most 0.030"));
    }
}
