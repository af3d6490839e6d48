//! `--dt auto`: choose the substeps per frame from the stability estimate and a requested
//! accuracy. The error of a step size is measured, not guessed: a short probe run at dt and at
//! dt/2 gives, by Richardson's estimate, the error of the dt run, |x_dt − x_dt/2| · 2^p/(2^p − 1)
//! for an integrator of order p. dt shrinks until that RMS error is within the tolerance.

use std::sync::Arc;

use crate::backend;
use crate::error::Result;
use crate::integrator::Step;
use crate::model::Model;
use crate::run::select::Device;
use crate::scene::settings::Settings;
use crate::stability::stable_dts;

/// What `--dt auto` picked, and why.
#[derive(Debug, Clone)]
pub struct AutoDt {
    pub substeps: u32,
    pub dt_secs: f64,
    /// Half the estimated stable step (no limit for implicit Euler).
    pub stability_cap_secs: Option<f64>,
    /// Estimated RMS position error over the probe at the chosen dt.
    pub estimated_error_m: f64,
    pub probe_secs: f64,
    /// False when smaller steps stopped reducing the error (f32 round-off) before the tolerance
    /// was met: the step with the smallest error is used.
    pub reached: bool,
}

impl std::fmt::Display for AutoDt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "--dt auto: {} substeps per frame (dt = {:.3e} s)",
            self.substeps, self.dt_secs
        )?;
        if let Some(c) = self.stability_cap_secs {
            write!(f, "; half the estimated stable step is {c:.3e} s")?;
        }
        write!(
            f,
            "; estimated RMS position error {:.2e} m over a {:.3} s probe (step doubling)",
            self.estimated_error_m, self.probe_secs
        )?;
        if !self.reached {
            write!(
                f,
                "; the tolerance is below what this integrator reaches in f32 here, so this is the most accurate step found"
            )?;
        }
        Ok(())
    }
}

fn positions_after(
    model: &Arc<Model>,
    device: &Device,
    step: Step,
    steps: u64,
) -> Result<Vec<glam::Vec3>> {
    let mut be = device.create(model.clone(), step)?;
    backend::advance_steps(be.as_mut(), steps, 1000)?;
    Ok(be.state()?.x)
}

/// Pick substeps for `settings` (its integrator and frame rate) so that the probe's estimated
/// RMS error is at most `tolerance_m`.
pub fn choose(
    model: &Arc<Model>,
    settings: &Settings,
    device: &Device,
    tolerance_m: f64,
) -> Result<AutoDt> {
    let integrator = settings.integrator;
    let frame = 1.0 / settings.frame_rate_hz;
    let cap = stable_dts(model)
        .into_iter()
        .find(|(i, _)| *i == integrator)
        .and_then(|(_, l)| l)
        .filter(|l| l.is_finite())
        .map(|l| 0.5 * l);
    // A scheme with no stable step at all (forward Euler undamped) still gets a small one.
    let cap = if integrator.unconditionally_stable() {
        None
    } else {
        Some(cap.unwrap_or(frame / 1000.0))
    };
    let probe = (5.0 * frame).min(settings.duration_secs());
    let p = f64::from(integrator.order());
    let mut substeps = cap.map_or(1.0, |c| (frame / c).ceil()).max(1.0) as u32;
    let mut error = f64::INFINITY;
    let mut best = (substeps, f64::INFINITY);
    let mut reached = false;
    for _ in 0..6 {
        let dt = frame / f64::from(substeps);
        let steps = (probe / dt).round().max(1.0) as u64;
        let at = |dt_secs| Step {
            dt_secs,
            ..settings.step()
        };
        let coarse = positions_after(model, device, at(dt), steps)?;
        let fine = positions_after(model, device, at(dt / 2.0), 2 * steps)?;
        let sq: f64 = coarse
            .iter()
            .zip(&fine)
            .map(|(a, b)| f64::from(a.distance_squared(*b)))
            .sum();
        error = (sq / coarse.len().max(1) as f64).sqrt() * 2f64.powf(p) / (2f64.powf(p) - 1.0);
        if error <= tolerance_m {
            reached = true;
            break;
        }
        if error > 0.7 * best.1 {
            // A smaller step did not help: round-off, not truncation, is what is left.
            (substeps, error) = best;
            break;
        }
        best = (substeps, error);
        // Error ∝ dt^p: shrink to meet the tolerance, with a margin, at least by half.
        let factor = (error / tolerance_m).powf(1.0 / p) * 1.2;
        substeps = (f64::from(substeps) * factor.max(2.0)).ceil().min(1e5) as u32;
    }
    Ok(AutoDt {
        substeps,
        dt_secs: frame / f64::from(substeps),
        stability_cap_secs: cap,
        estimated_error_m: error,
        probe_secs: probe,
        reached,
    })
}
