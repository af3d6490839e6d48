//! `hooke bench stability`: each integrator's estimated stable step (`hooke check`'s)
//! beside the largest stable step measured by bisection, scene by scene, so that the promise
//! "the estimate never overshoots" is checked against the scenes themselves.

use std::fmt::Write as _;

use crate::error::Result;
use crate::integrator::{Integrator, Unsupported};
use crate::run::prepare::{self, Request};
use crate::run::select::Device;
use crate::stability::{Modes, stable_step};

use super::results::Found;
use super::stable_dt::{search_range, search_stable_dt_on};

/// One scene and integrator: the estimate, what binds it, and the measurement.
#[derive(Debug, Clone)]
pub struct LimitRow {
    pub scene: String,
    pub integrator: Integrator,
    pub scene_dt_secs: f64,
    /// `None`: unstable at any practical step.
    pub estimate_secs: Option<f64>,
    pub limit: Option<&'static str>,
    /// Where no step is stable for sure: what the dashpots along the springs would allow.
    pub dashpot_line_secs: Option<f64>,
    pub measured: Measured,
}

/// What the search found, or why nothing was searched.
#[derive(Debug, Clone, Copy)]
pub enum Measured {
    Found(Found),
    /// The scene asks for an effect the integrator refuses: a run would not start.
    Refused(Unsupported),
}

/// How far a search must find a scheme stable before its estimate "any step" counts as holding,
/// and how far "any" is judged: a limit found beyond it is printed, not counted against it.
/// A tenth of a second is six frames at 60 Hz: no scene is stepped coarser. Each search's top
/// is the first doubling of the scene's step past it (0.107 to 0.178 s), so judged to its top,
/// "any" held or failed by how far a scene's ladder happened to reach (the jello's stops at
/// 0.107 s; the blob's found its BDF2 limit at 0.111 s).
pub const ANY_STEP_MEASURED_TO_SECS: f64 = 0.1;

impl LimitRow {
    /// The estimate is at or below the measured step (or both say "no stable step"). An
    /// estimate of any step holds where the scheme was measured stable to at least
    /// [`ANY_STEP_MEASURED_TO_SECS`]: up to the search's top, or to a limit found beyond it. A
    /// finite estimate beyond the search's top (a collider crossed only at a third of a second)
    /// holds where that top is past it too: it is measured as far as "any" is.
    pub fn holds(&self) -> bool {
        let Measured::Found(found) = self.measured else {
            return true;
        };
        match (self.estimate_secs, found) {
            (None, _) => true,
            (Some(e), Found::Largest(m)) if e.is_infinite() => m >= ANY_STEP_MEASURED_TO_SECS,
            (Some(e), Found::AtLeast(m)) if e > m => m >= ANY_STEP_MEASURED_TO_SECS,
            (Some(e), Found::Largest(m) | Found::AtLeast(m)) => e <= m,
            (Some(_), Found::Unstable) => false,
        }
    }
}

/// Measure each of `integrators`' largest stable step on each scene, `duration` simulated
/// seconds per trial, on `device`; `progress` hears of each finished search. Returns the rows
/// and the device's name.
pub fn measure_limits(
    scenes: &[String],
    integrators: &[Integrator],
    device: &Device,
    duration: f64,
    progress: &mut dyn FnMut(&LimitRow),
) -> Result<(Vec<LimitRow>, String)> {
    let mut rows = Vec::new();
    let mut device_name = String::new();
    for scene in scenes {
        let planned = prepare::plan(&Request::named(scene, device.clone()), &mut |_| {})?;
        let (model, scene_dt) = (&planned.model, planned.settings.dt_secs);
        if device_name.is_empty() {
            device_name = device
                .create(model.clone(), planned.settings.step())?
                .describe();
        }
        let modes = Modes::of(model);
        for &integrator in integrators {
            let estimate = stable_step(&modes, integrator);
            // Where no step is stable for sure, search around the dashpots' line.
            let centre = estimate.finite_dt().or(estimate.dashpot_line_secs);
            let range = search_range(integrator, centre, scene_dt);
            let row = LimitRow {
                scene: planned.loaded.scene.name.clone(),
                integrator,
                scene_dt_secs: scene_dt,
                estimate_secs: estimate.dt_secs,
                limit: estimate.limit.map(|l| l.name()),
                dashpot_line_secs: estimate.dashpot_line_secs,
                measured: match integrator.supports(&model.effects) {
                    Ok(()) => Measured::Found(search_stable_dt_on(
                        model, device, integrator, range, duration,
                    )),
                    Err(refused) => Measured::Refused(refused),
                },
            };
            progress(&row);
            rows.push(row);
        }
    }
    Ok((rows, device_name))
}

/// The table, as Markdown: one row per scene and integrator.
pub fn limits_markdown(rows: &[LimitRow], duration: f64, device: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Largest stable dt: `hooke check`'s estimate against bisection ({duration} s of simulated \
         time per trial, stable = finite and gaining under a tenth of the initial energy; \
         \"any\" is judged to {ANY_STEP_MEASURED_TO_SECS} s, a limit found beyond it printed \
         but not counted against it; {device}).\n"
    );
    let _ = writeln!(
        s,
        "| scene | integrator | scene's dt | estimate | limit | measured | estimate / measured |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---|---:|---:|");
    for r in rows {
        let estimate = match (r.estimate_secs, r.dashpot_line_secs) {
            (Some(e), _) if e.is_infinite() => "any".to_owned(),
            (Some(e), _) => format!("{e:.3e} s"),
            (None, Some(line)) => format!("none for sure (dashpots: {line:.3e} s)"),
            (None, None) => "none".to_owned(),
        };
        let (measured, found) = match r.measured {
            Measured::Found(Found::Largest(m)) => (format!("{m:.3e} s"), Some(m)),
            Measured::Found(Found::AtLeast(m)) => (format!("≥ {m:.3e} s"), Some(m)),
            Measured::Found(Found::Unstable) => ("unstable".to_owned(), None),
            Measured::Refused(why) => (format!("refused ({})", why.effect()), None),
        };
        let ratio = match (r.estimate_secs, found) {
            (Some(e), Some(m)) if e.is_finite() => format!("{:.2}", e / m),
            _ => "—".to_owned(),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.3e} s | {estimate} | {} | {measured} | {ratio}{} |",
            r.scene,
            r.integrator,
            r.scene_dt_secs,
            r.limit.unwrap_or("—"),
            if r.holds() { "" } else { " **overshoots**" }
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(estimate_secs: Option<f64>, found: Found) -> LimitRow {
        LimitRow {
            scene: "s".to_owned(),
            integrator: Integrator::ALL[0],
            scene_dt_secs: 1e-3,
            estimate_secs,
            limit: None,
            dashpot_line_secs: None,
            measured: Measured::Found(found),
        }
    }

    /// "Any step" holds where the scheme was measured stable to a tenth of a second; a limit
    /// found below it refutes it.
    #[test]
    fn any_step_holds_only_as_far_as_it_was_measured() {
        let any = Some(f64::INFINITY);
        assert!(row(any, Found::AtLeast(0.142)).holds());
        assert!(!row(any, Found::AtLeast(0.05)).holds());
        assert!(row(any, Found::Largest(0.111)).holds());
        assert!(!row(any, Found::Largest(0.087)).holds());
        // A finite estimate beyond the search's top is measured as far as "any" is.
        assert!(row(Some(0.333), Found::AtLeast(0.142)).holds());
        assert!(!row(Some(0.333), Found::AtLeast(0.05)).holds());
        assert!(row(Some(1e-3), Found::Largest(2e-3)).holds());
        assert!(!row(Some(3e-3), Found::Largest(2e-3)).holds());
        assert!(!row(Some(1e-3), Found::Unstable).holds());
        assert!(row(None, Found::Unstable).holds());
    }
}
