//! A backend's whole instruction for stepping: the integrator, its step and its options.

use super::options::StepOptions;
use super::table::Integrator;

/// How a backend steps: the integrator, its step and its options. Both backends take one; a
/// run's comes from its [`Settings`](crate::scene::settings::Settings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    pub integrator: Integrator,
    pub dt_secs: f64,
    pub options: StepOptions,
}

impl Step {
    /// `integrator` at `dt_secs`, with the default options.
    pub fn new(integrator: Integrator, dt_secs: f64) -> Self {
        Self {
            integrator,
            dt_secs,
            options: StepOptions::default(),
        }
    }

    pub fn with_options(self, options: StepOptions) -> Self {
        Self { options, ..self }
    }
}
