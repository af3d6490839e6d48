//! How large a step the scene survives: the region its modes lie in (`modes`), each
//! integrator's largest stable step over that region and the limit that binds (`estimate`),
//! and what a user is told when the chosen step is above it (`advice`).

mod advice;
mod estimate;
mod modes;

pub use advice::{Refusal, dt_warning, stable_dts};
pub use estimate::{Limit, StableStep, stable_step, stable_steps};
pub use modes::{Bound, Modes, Ratios, Source};
