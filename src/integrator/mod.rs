//! The integrators, what they cost, and how large a step each survives: one file per scheme
//! (`euler.rs` … `bdf2.rs`), each a row of the table (`table.rs`) in the shape `descriptor.rs`
//! gives it. The stability of each is judged on the test oscillator (`oscillator.rs`); the
//! effects a scheme refuses (`effects.rs`), its options (`options.rs`) and a backend's whole
//! instruction, the [`Step`] (`step.rs`), sit beside them.

mod bdf2;
mod descriptor;
mod effects;
mod euler;
mod implicit;
mod options;
mod oscillator;
mod rk2;
mod rk4;
mod semi_implicit;
mod step;
mod table;
mod vbd;
mod verlet;
mod xpbd;

pub use descriptor::{Amplification, Explicit, Over, Scheme, Solve, StableStep, Sweeps};
pub use effects::{AskedEffects, Unsupported};
pub use options::{
    DEFAULT_VBD_ITERATIONS, DEFAULT_XPBD_ITERATIONS, MULTIGRID_MIN_MASSES, MULTIGRID_MIN_STIFFNESS,
    Preconditioner, StepOptions,
};
pub use oscillator::Oscillator;
pub use step::Step;
pub use table::Integrator;
