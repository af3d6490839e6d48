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
/// small-dt runs to none) when the estimate is good. Stability need not be monotonic in dt
/// ([`search_with`] says how the octave below the result is checked).
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
    range: (f64, f64),
    duration: f64,
) -> Found {
    search_with(
        &|dt| is_stable_on(model, device, integrator, dt, duration),
        range,
    )
}

/// Steps per octave at which the octave below a search's result is tried again.
const CHECKED_PER_OCTAVE: i32 = 4;

/// [`search_stable_dt`]'s search over any test of stability. Stability is not always monotonic
/// in dt: BDF2 on the jello, before it restarted across impacts, held at 9.6e-2 s (where the
/// bisection ended) and failed at 7e-2 to 8e-2 s, between the doublings it tried
/// (docs/stability.md). So a result is only taken once every quarter octave of the octave below
/// it holds too (within `[lo, hi]`); where one fails, the search goes on below that one.
pub fn search_with(stable: &dyn Fn(f64) -> bool, (lo, hi): (f64, f64)) -> Found {
    let start = (lo * hi).sqrt();
    let (mut good, mut bad): (f64, Option<f64>);
    if stable(start) {
        good = start;
        loop {
            if good >= hi {
                break;
            }
            let next = (2.0 * good).min(hi);
            if stable(next) {
                good = next;
            } else {
                break;
            }
        }
        bad = (good < hi).then_some((2.0 * good).min(hi));
    } else {
        let mut b = start;
        loop {
            if b <= lo {
                return Found::Unstable;
            }
            let next = (0.5 * b).max(lo);
            if stable(next) {
                good = next;
                break;
            }
            b = next;
        }
        bad = Some(b);
    }
    loop {
        if let Some(mut b) = bad {
            while b / good > SEARCH_PRECISION {
                let mid = (good * b).sqrt();
                if stable(mid) {
                    good = mid;
                } else {
                    b = mid;
                }
            }
        }
        match failure_below(stable, good, lo) {
            None if bad.is_none() => return Found::AtLeast(good),
            None => return Found::Largest(good),
            Some((failed, Some(held))) => (good, bad) = (held, Some(failed)),
            Some((_, None)) => return Found::Unstable,
        }
    }
}

/// The highest quarter octave of the octave below `good` (within `lo`) that fails, with the
/// highest step below it that holds (trying on down, within `lo`), if one fails.
fn failure_below(stable: &dyn Fn(f64) -> bool, good: f64, lo: f64) -> Option<(f64, Option<f64>)> {
    let step = |k: i32| good * 2f64.powf(-f64::from(k) / f64::from(CHECKED_PER_OCTAVE));
    let failed = (1..=CHECKED_PER_OCTAVE)
        .map(step)
        .take_while(|dt| *dt >= lo)
        .find(|dt| !stable(*dt))?;
    let below = (1..)
        .map(|k| failed * 2f64.powf(-f64::from(k) / f64::from(CHECKED_PER_OCTAVE)))
        .take_while(|dt| *dt >= lo)
        .find(|dt| stable(*dt));
    Some((failed, below))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A limit found by bisection is taken only when the octave below it holds: a test of
    /// stability that fails in a window below the doubling ladder's last stable step is found
    /// out, and the search ends below the window; a monotonic one ends at its limit.
    #[test]
    fn a_search_looks_below_its_limit_for_a_window_that_fails() {
        // The bisection passes the window by (7.4e-2, 8.8e-2, 9.6e-2 s, … to 0.1 s); the
        // octave below finds it at 8.4e-2 s.
        let window = |dt: f64| !(0.078..=0.086).contains(&dt) && dt <= 0.1;
        let Found::Largest(found) = search_with(&window, (4e-4, 0.1067)) else {
            panic!("no limit");
        };
        assert!(found < 0.078 && found > 0.078 / SEARCH_PRECISION, "{found}");
        let monotonic = |dt: f64| dt <= 0.1;
        let Found::Largest(found) = search_with(&monotonic, (4e-4, 0.1067)) else {
            panic!("no limit");
        };
        assert!(found <= 0.1 && found > 0.1 / SEARCH_PRECISION, "{found}");
        // Stable to the top, but for a window in the octave below it: not "at least the top".
        let top = search_with(&|dt| !(0.085..=0.092).contains(&dt), (4e-4, 0.1067));
        assert!(matches!(top, Found::Largest(f) if f < 0.085), "{top:?}");
        assert_eq!(
            search_with(&|_| true, (4e-4, 0.1067)),
            Found::AtLeast(0.1067)
        );
        assert_eq!(search_with(&|_| false, (4e-4, 0.1067)), Found::Unstable);
    }
}
