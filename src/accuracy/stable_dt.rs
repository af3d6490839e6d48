//! The largest stable step of an integrator, found by bisection on the CPU: what "stable" means
//! (no energy gained beyond a tenth of the initial, damping is no divergence) and where to look.

use std::sync::Arc;

use crate::backend::{self, Backend, BackendError};
use crate::integrator::{Integrator, Step};
use crate::model::Model;
use crate::run::select::Device;

use super::results::Found;

/// Implicit Euler is searched from the scene's dt up to at least this (one step per 10 frames
/// at 60 Hz): where users take it.
pub const IMPLICIT_SEARCH_UP_TO_SECS: f64 = 0.1;

/// The energy against which a run's balance drift is judged: the initial mechanical energy.
pub fn energy_scale(model: &Model) -> f64 {
    let e0 = crate::cpu::compute_energies(model, &model.springs, &model.initial);
    e0.total_j().abs().max(e0.kinetic_j).max(1e-6)
}

/// Stable: stays finite, and gains less than a tenth of the initial mechanical energy (a weakly
/// unstable scheme grows without ever overflowing in a short run). Losing energy is not
/// instability: a damped, bounded run is stable, and its loss is reported apart.
pub fn stayed_stable(balance_change_j: f64, scale: f64) -> bool {
    balance_change_j.is_finite() && balance_change_j < 0.1 * scale
}

/// Energy lost beyond the ledger, in percent of `scale`.
pub fn dissipated_pct(balance_change_j: f64, scale: f64) -> f64 {
    if balance_change_j.is_finite() {
        100.0 * (-balance_change_j).max(0.0) / scale
    } else {
        f64::NAN
    }
}

/// Whether `integrator` at `dt` runs `duration` on the CPU without diverging (see
/// [`stayed_stable`]).
pub fn is_stable(model: &Arc<Model>, integrator: Integrator, dt: f64, duration: f64) -> bool {
    is_stable_on(model, &Device::cpu(), integrator, dt, duration)
}

/// [`is_stable`] on any device. A device that cannot be opened counts as no answer: unstable.
pub fn is_stable_on(
    model: &Arc<Model>,
    device: &Device,
    integrator: Integrator,
    dt: f64,
    duration: f64,
) -> bool {
    let steps = (duration / dt).ceil() as u64;
    let Ok(mut be) = device.create(model.clone(), Step::new(integrator, dt)) else {
        return false;
    };
    run_steps(be.as_mut(), steps).is_ok_and(|change| stayed_stable(change, energy_scale(model)))
}

fn run_steps(be: &mut dyn Backend, steps: u64) -> std::result::Result<f64, BackendError> {
    let b0 = be.snapshot(0, Default::default())?.energies.balance_j();
    backend::advance_steps(be, steps, 1_000)?;
    Ok(be.snapshot(0, Default::default())?.energies.balance_j() - b0)
}

/// Searches stop once the stable and the unstable step are this close (ratio): 0.5%.
const SEARCH_PRECISION: f64 = 1.005;

/// The largest stable dt within `[lo, hi]`: from the range's geometric middle (the estimate,
/// where there is one), doubling or halving until stability changes, then bisecting in log dt
/// between the two. Starting at the middle, not at `lo`, keeps the runs to few (and costly
/// small-dt runs to none) when the estimate is good.
pub fn search_stable_dt(
    model: &Arc<Model>,
    integrator: Integrator,
    range: (f64, f64),
    duration: f64,
) -> Found {
    search_stable_dt_on(model, &Device::cpu(), integrator, range, duration)
}

/// [`search_stable_dt`] on any device.
pub fn search_stable_dt_on(
    model: &Arc<Model>,
    device: &Device,
    integrator: Integrator,
    (lo, hi): (f64, f64),
    duration: f64,
) -> Found {
    let stable = |dt| is_stable_on(model, device, integrator, dt, duration);
    let start = (lo * hi).sqrt();
    let (mut good, mut bad);
    if stable(start) {
        good = start;
        loop {
            if good >= hi {
                return Found::AtLeast(hi);
            }
            let next = (2.0 * good).min(hi);
            if stable(next) {
                good = next;
            } else {
                bad = next;
                break;
            }
        }
    } else {
        bad = start;
        loop {
            if bad <= lo {
                return Found::Unstable;
            }
            let next = (0.5 * bad).max(lo);
            if stable(next) {
                good = next;
                break;
            }
            bad = next;
        }
    }
    while bad / good > SEARCH_PRECISION {
        let mid = (good * bad).sqrt();
        if stable(mid) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    Found::Largest(good)
}

/// Where to search each integrator's largest stable dt: 16× either side of the estimate (of
/// the scene's dt where there is none); implicit Euler, VBD and XPBD (A-stable on one spring) from
/// the scene's dt to at least [`IMPLICIT_SEARCH_UP_TO_SECS`], in whole doublings.
pub fn search_range(integrator: Integrator, estimate: Option<f64>, scene_dt: f64) -> (f64, f64) {
    match (integrator, estimate) {
        (i, _) if i.unconditionally_stable() => {
            let doublings = (IMPLICIT_SEARCH_UP_TO_SECS / scene_dt)
                .log2()
                .ceil()
                .max(0.0);
            (scene_dt, scene_dt * 2f64.powf(doublings))
        }
        (_, Some(e)) if e.is_finite() => (e / 16.0, e * 16.0),
        _ => (scene_dt / 16.0, scene_dt * 16.0),
    }
}
