//! Whether a step is large enough for f32 to see: positions and velocities are f32 on both
//! backends, so a step whose move `dt · v` is under half a unit in the last place of a mass's
//! coordinate leaves the mass where it was. Far enough below that, every body freezes in place
//! while the clock (f64) runs on: 4 000 000 000 substeps a frame of the jello (dt = 4.2e-12 s)
//! would move nothing slower than 1.3e4 m/s, and take days a frame to show it.

use crate::model::Model;
use crate::scene::MAX_START_SPEED_M_PER_S;

/// Below this speed a mass that cannot move at the step is worth a warning: bodies at rest,
/// swinging or falling for a second go about this fast.
pub const NOTICEABLE_SPEED_M_PER_S: f32 = 1.0;

/// How fast a mass must go at `dt_secs` to move at all where the model's masses are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolution {
    pub dt_secs: f64,
    /// The largest distance of a mass from the origin at the start, in metres.
    pub reach_m: f32,
    /// Slower masses there stay where they are: half the f32 spacing at `reach_m`, over dt.
    pub least_speed_m_per_s: f64,
}

impl Resolution {
    /// The step at which a mass at `reach_m` moving at `speed` moves by half an f32 spacing.
    pub fn least_dt_for(&self, speed_m_per_s: f32) -> f64 {
        self.least_speed_m_per_s * self.dt_secs / f64::from(speed_m_per_s)
    }
}

/// The resolution of `model`'s positions at a step of `dt_secs`.
pub fn resolution(model: &Model, dt_secs: f64) -> Resolution {
    let reach_m = model
        .initial
        .x
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0f32, f32::max);
    // One f32 spacing at r is at most r · EPSILON; a move under half of it rounds away.
    let spacing = f64::from(reach_m.max(f32::MIN_POSITIVE) * f32::EPSILON);
    Resolution {
        dt_secs,
        reach_m,
        least_speed_m_per_s: 0.5 * spacing / dt_secs,
    }
}

/// A step so small that nothing a scene may hold moves at it.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error(
    "dt = {dt:.3e} s is below what f32 positions resolve: a mass {reach:.3} m from the origin moves \
     only if it goes faster than {speed:.1e} m/s, above the {most:.0e} m/s any scene may start with, \
     so every body would freeze while the clock runs. Use a dt of at least {least:.1e} s (fewer \
     substeps), or put the scene nearer the origin",
    dt = .0.dt_secs,
    reach = .0.reach_m,
    speed = .0.least_speed_m_per_s,
    most = MAX_START_SPEED_M_PER_S,
    least = .0.least_dt_for(NOTICEABLE_SPEED_M_PER_S),
)]
pub struct BelowResolution(pub Resolution);

/// A step at which slow masses cannot move: the warning of [`check_resolution`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearResolution(pub Resolution);

impl std::fmt::Display for NearResolution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = &self.0;
        write!(
            f,
            "dt = {:.3e} s is near what f32 positions resolve: a mass {:.3} m from the origin \
             stays where it is unless it goes faster than {:.2} m/s; a dt of {:.1e} s or more \
             moves everything faster than {NOTICEABLE_SPEED_M_PER_S} m/s",
            r.dt_secs,
            r.reach_m,
            r.least_speed_m_per_s,
            r.least_dt_for(NOTICEABLE_SPEED_M_PER_S),
        )
    }
}

/// `Err` where nothing can move at `dt_secs`; `Ok(Some(warning))` where slow masses cannot.
pub fn check_resolution(
    model: &Model,
    dt_secs: f64,
) -> Result<Option<NearResolution>, BelowResolution> {
    let r = resolution(model, dt_secs);
    if r.least_speed_m_per_s > f64::from(MAX_START_SPEED_M_PER_S) {
        return Err(BelowResolution(r));
    }
    if r.least_speed_m_per_s > f64::from(NOTICEABLE_SPEED_M_PER_S) {
        return Ok(Some(NearResolution(r)));
    }
    Ok(None)
}
