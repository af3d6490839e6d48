//! What a user is told before stepping when the chosen step is above the estimate.

use crate::integrator::{Integrator, StepOptions, Unsupported};
use crate::model::Model;
use crate::scene::settings::Settings;

use super::estimate::{Limit, stable_step_with, stable_steps};
use super::modes::Modes;

/// Estimated largest stable dt for each integrator, XPBD's and VBD's with their default sweeps;
/// `None` where the scheme is unstable at any practical dt.
pub fn stable_dts(model: &Model) -> Vec<(Integrator, Option<f64>)> {
    stable_steps(&Modes::of(model), &StepOptions::default())
        .into_iter()
        .map(|s| (s.integrator, s.dt_secs))
        .collect()
}

/// Is the chosen dt above the estimated limit of the chosen integrator? Names the limit (the
/// stiffness, the damping or too little of it; the mass and the spring kind) and the step that
/// would hold.
///
/// Where XPBD's or VBD's sweeps bind, [`super::sweep_warning`] says it, with what would do.
pub fn dt_warning(model: &Model, settings: &Settings) -> Option<StepWarning> {
    let step = stable_step_with(&Modes::of(model), settings.integrator, &settings.options);
    let (integrator, dt_secs, limit) = (settings.integrator, settings.dt_secs, step.limit);
    if let Some(Limit::Sweeps(_)) = limit {
        return None;
    }
    match step.dt_secs {
        Some(l) if dt_secs <= l => None,
        Some(stable_secs) => Some(StepWarning::AboveEstimate {
            integrator,
            dt_secs,
            stable_secs,
            limit,
            substeps: (1.0 / (settings.frame_rate_hz * stable_secs)).ceil(),
        }),
        None => Some(StepWarning::NoStableStep {
            integrator,
            dt_secs,
            limit,
            dashpot_line_secs: step.dashpot_line_secs,
        }),
    }
}

/// A step above the estimate of its integrator on the scene, as [`dt_warning`] finds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepWarning {
    /// Above the estimated stable step, `stable_secs`, which `substeps` a frame would keep.
    AboveEstimate {
        integrator: Integrator,
        dt_secs: f64,
        stable_secs: f64,
        limit: Option<Limit>,
        substeps: f64,
    },
    /// The integrator has no step stable for sure on the scene; the dashpots along the
    /// springs allow at most `dashpot_line_secs`, where they bound it.
    NoStableStep {
        integrator: Integrator,
        dt_secs: f64,
        limit: Option<Limit>,
        dashpot_line_secs: Option<f64>,
    },
}

impl std::fmt::Display for StepWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let limit = |limit: &Option<Limit>| {
            limit
                .map(|l| format!(" ({} limit: {l})", l.name()))
                .unwrap_or_default()
        };
        match self {
            StepWarning::AboveEstimate {
                integrator,
                dt_secs,
                stable_secs,
                limit: l,
                substeps,
            } => write!(
                f,
                "dt = {dt_secs:.3e} s is above the estimated stable step {stable_secs:.3e} s of \
                 `{integrator}` on this scene{}; use at least {substeps} substeps per frame (or \
                 --dt {stable_secs:.3e})",
                limit(l)
            ),
            StepWarning::NoStableStep {
                integrator,
                dt_secs,
                limit: l,
                dashpot_line_secs,
            } => write!(
                f,
                "dt = {dt_secs:.3e} s: `{integrator}` has no step that is stable for sure on this \
                 scene{}{}; prefer {}",
                limit(l),
                dashpot_line_secs
                    .map(|l| format!("; the dashpots along the springs allow at most {l:.3e} s"))
                    .unwrap_or_default(),
                instead_of(*integrator)
            ),
        }
    }
}

/// What to use instead of `integrator` where it has no step stable for sure: the explicit
/// schemes with a stable step, less the one in use, and where that is one of them, the implicit
/// schemes, stable at any step.
fn instead_of(integrator: Integrator) -> String {
    let explicit = Integrator::STABLE_EXPLICIT;
    let others: Vec<&str> = explicit
        .iter()
        .filter(|&&i| i != integrator)
        .map(|i| i.name())
        .collect();
    match explicit.contains(&integrator) {
        true => format!(
            "implicit or bdf2 (stable at any step), or {}",
            others.join(" or ")
        ),
        false => others.join(", "),
    }
}

/// Why an integrator at a step is refused for a scene before anything runs (an entry of a
/// comparison).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Refusal {
    #[error("{0} ([{field}] in this scene)", field = .0.scene_field())]
    Unsupported(Unsupported),
    #[error(
        "dt = {dt_secs:.3e} s is above the estimated stable step {limit_secs:.3e} s of `{integrator}` on this scene{why}; \
         give it a step of {limit_secs:.3e} s or less ({integrator}@{limit_secs:.3e}){others}",
        why = limit.map(|l| format!(" ({} limit: {l})", l.name())).unwrap_or_default(),
        others = match limit {
            // A collider's crossing holds every scheme to the step.
            Some(Limit::Crossing(_)) => "",
            _ => ", or use implicit or xpbd for large steps",
        }
    )]
    AboveStableStep {
        integrator: Integrator,
        dt_secs: f64,
        limit_secs: f64,
        limit: Option<Limit>,
    },
}
