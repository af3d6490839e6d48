//! How large a step the scene survives: the region its modes lie in (`modes`), each
//! integrator's largest stable step over that region and the limit that binds (`estimate`),
//! what a user is told when the chosen step is above it (`advice`), and whether XPBD's or VBD's
//! fixed sweeps converge the springs at the step, or leave them fast and wrong (`sweeps`), and
//! whether the step is large enough for f32 positions to move at all (`resolution`), and the
//! step at which a mass can cross a collider's middle, which bounds every scheme (`crossing`).

mod advice;
mod crossing;
pub mod divergence;
mod estimate;
mod modes;
mod resolution;
mod sweeps;

pub use advice::{Refusal, StepWarning, dt_warning, stable_dts};
pub use crossing::Crossing;
pub use estimate::{Limit, StableStep, stable_step, stable_step_with, stable_steps};
pub use modes::{Bound, Modes, Ratios, Source};
pub use resolution::{BelowResolution, NearResolution, Resolution, check_resolution, resolution};
pub use sweeps::{
    Converging, SWEEPS_ENOUGH, SweepReach, SweepShortfall, SweepWarning, sweep_shortfall,
    sweep_warning,
};
