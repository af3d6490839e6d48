//! Each integrator's largest stable step over the whole region of modes ([`Modes`]): the
//! largest dt at which every scalar oscillator in the region keeps the scheme's amplification at
//! most 1, and which limit binds there.
//!
//! For the Runge–Kutta schemes (Euler, RK2, RK4) applied to the linearised system, the step's
//! eigenvalues are R(hλ) over the system's eigenvalues λ, each a root of some oscillator in the
//! region: the estimate is a bound. For semi-implicit Euler, whose iteration's eigenvalues μ
//! solve (μ−1)² + h(μ−1)c_u + h²μ k_u = 0, likewise; its worst oscillator is the corner
//! (ω_max, γ_max), so its estimate is 2(√(ζ²+1) − ζ)/ω_max with the corner's ζ. Velocity Verlet
//! evaluates C at a predicted velocity, which couples K and C, so for it the region is the
//! model, checked against measurement (docs/stability.md).
//!
//! XPBD and VBD are stable on any one spring. On a body, a fixed number of Gauss–Seidel sweeps a
//! step stops converging its springs as the step grows (`sweeps.rs`): beyond that step the body
//! stays stretched far past its springs' rest, and the energy of that stretch swings above the
//! start, which `hooke bench stability` measures as a gain. Their estimate is that step; XPBD's
//! is also held by the forces it steps as semi-implicit Euler does (contacts and drag, the
//! springs aside: [`Modes::unprojected`]).

use crate::integrator::{Integrator, StepOptions};

use super::crossing::Crossing;
use super::modes::{Modes, Source};
use super::sweeps::Converging;

/// What sets an integrator's stable step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Limit {
    /// The stiffest mode oscillates too fast for the step.
    Stiffness {
        omega_rad_per_s: f64,
        mass: u32,
        source: Source,
    },
    /// The dashpots (or contact damping) act faster than the step can follow: an overdamped
    /// mode overshoots.
    Damping {
        rate_per_s: f64,
        mass: u32,
        source: Source,
    },
    /// The scheme needs damping to be stable at all (forward Euler, RK2), and the dashpot
    /// weakest for its spring gives too little: its c/k ratio bounds the step.
    WeakDamping { ratio_s: f64, source: Source },
    /// XPBD's or VBD's sweeps a step stop converging a body's springs: stable on each spring,
    /// the body stays stretched far past its springs' rest, with that stretch's energy.
    Sweeps(Converging),
    /// A mass can cross a collider's middle in one step and be pushed out of its far side.
    Crossing(Crossing),
}

impl Limit {
    /// Which limit, in a few words: "stiffness", "damping", "weak damping", "sweeps" or
    /// "collider crossing".
    pub fn name(&self) -> &'static str {
        match self {
            Limit::Stiffness { .. } => "stiffness",
            Limit::Damping { .. } => "damping",
            Limit::WeakDamping { .. } => "weak damping",
            Limit::Sweeps(_) => "sweeps",
            Limit::Crossing(_) => "collider crossing",
        }
    }
}

impl std::fmt::Display for Limit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Limit::Stiffness {
                omega_rad_per_s,
                mass,
                source,
            } => write!(
                f,
                "the stiffness of the {source} at mass {mass} (stiffest mode ω ≤ {omega_rad_per_s:.3e} rad/s)"
            ),
            Limit::Damping {
                rate_per_s,
                mass,
                source,
            } => {
                if source == Source::AirDrag {
                    f.write_str("the air drag")?;
                } else {
                    write!(f, "the dashpots of the {source} at mass {mass}")?;
                }
                write!(f, " (most damped mode γ ≤ {rate_per_s:.3e} /s)")
            }
            Limit::WeakDamping { ratio_s, source } => write!(
                f,
                "too little damping for a scheme that amplifies every undamped oscillation: the {source} have c/k = {ratio_s:.3e} s along them, and a swing across stretched springs has no dashpot at all"
            ),
            Limit::Crossing(c) => write!(f, "{c}"),
            Limit::Sweeps(c) => {
                let reach = if c.pinned {
                    format!(
                        "a body whose farthest mass is {} springs from a pin",
                        c.hops
                    )
                } else {
                    format!("a body {} springs across", c.hops)
                };
                write!(
                    f,
                    "beyond it {} sweep{} a step leave the springs of {reach} stretched, and the energy of that stretch swings above the start",
                    c.sweeps,
                    if c.sweeps == 1 { "" } else { "s" }
                )
            }
        }
    }
}

/// An integrator's estimated largest stable step and what sets it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StableStep {
    pub integrator: Integrator,
    /// `None`: unstable at any practical step (a scheme that needs damping, on modes with
    /// none). `Some(∞)`: stable at any step (implicit Euler, BDF2, or nothing stiff).
    pub dt_secs: Option<f64>,
    /// What binds at that step; `None` where nothing does.
    pub limit: Option<Limit>,
    /// For a scheme that needs damping in every mode (forward Euler, RK2): the largest step
    /// the dashpots along the springs would allow if every mode had them. No step is stable for
    /// sure ([`StableStep::dt_secs`] is `None`): a loaded or folded body swings across its
    /// stretched springs, where no dashpot acts and drag alone damps, and those schemes amplify
    /// an undamped oscillation at any step. How far below this line a scene holds is measured
    /// (`hooke bench stability`).
    pub dashpot_line_secs: Option<f64>,
}

impl StableStep {
    /// The estimate as a finite step, where it is one.
    pub fn finite_dt(&self) -> Option<f64> {
        self.dt_secs.filter(|dt| dt.is_finite())
    }
}

/// Oscillators sampled over the region: ω log-spaced over four decades below ω_max (below them,
/// every scheme here is limited by the same c/k line), γ across the band at each ω.
const OMEGAS: usize = 64;
const GAMMAS: usize = 9;

fn region(modes: &Modes) -> Vec<(f64, f64)> {
    let (w_max, g_max, d) = (
        modes.stiffest.value,
        modes.most_damped.value,
        modes.drag_per_s,
    );
    let (b_lo, b_hi) = modes.ratios.map_or((0.0, 0.0), |r| (r.least_s, r.most_s));
    let mut points = Vec::with_capacity(OMEGAS * GAMMAS);
    for a in 0..OMEGAS {
        let w = w_max * 10f64.powf(-4.0 * (1.0 - a as f64 / (OMEGAS - 1) as f64));
        let hi = (b_hi * w * w + d).min(g_max);
        let lo = (b_lo * w * w + d).min(hi);
        for b in 0..GAMMAS {
            points.push((w, lo + (hi - lo) * b as f64 / (GAMMAS - 1) as f64));
        }
    }
    points
}

/// The estimate for one integrator with its default sweeps.
pub fn stable_step(modes: &Modes, integrator: Integrator) -> StableStep {
    stable_step_with(modes, integrator, &StepOptions::default())
}

/// The estimate for one integrator with the sweeps of `options`. XPBD and VBD are stable on
/// any one spring, but not at any step on a body: theirs is the step at which their sweeps
/// still converge the springs, and XPBD's also that of the forces it steps as semi-implicit
/// Euler does (contacts and drag). Every scheme's is also held to the step at which a mass can
/// cross a collider's middle (`crossing.rs`).
pub fn stable_step_with(
    modes: &Modes,
    integrator: Integrator,
    options: &StepOptions,
) -> StableStep {
    let step = scheme_step(modes, integrator, options);
    match (modes.crossing, step.dt_secs) {
        (Some(c), Some(dt)) if c.dt_secs < dt => StableStep {
            dt_secs: Some(c.dt_secs),
            limit: Some(Limit::Crossing(c)),
            ..step
        },
        _ => step,
    }
}

/// The estimate of the scheme over the modes, colliders' crossing aside.
fn scheme_step(modes: &Modes, integrator: Integrator, options: &StepOptions) -> StableStep {
    let scheme = integrator.scheme();
    let Some(sweeps) = scheme.sweeps() else {
        return limited_step(modes, integrator);
    };
    let mut step = StableStep {
        integrator,
        dt_secs: Some(f64::INFINITY),
        limit: None,
        dashpot_line_secs: None,
    };
    if let Some(c) = modes.reach.converging(sweeps.count(options)) {
        step.dt_secs = Some(c.dt_secs);
        step.limit = Some(Limit::Sweeps(c));
    }
    let contacts_as = sweeps
        .contacts_as
        .and_then(|name| Integrator::ALL.into_iter().find(|i| i.name() == name));
    let unprojected = modes.unprojected.as_deref().zip(contacts_as);
    if let Some(explicit) = unprojected.map(|(m, i)| limited_step(m, i))
        && explicit.dt_secs < step.dt_secs
    {
        step.dt_secs = explicit.dt_secs;
        step.limit = explicit.limit;
    }
    step
}

/// The estimate for a scheme with no sweeps.
fn limited_step(modes: &Modes, integrator: Integrator) -> StableStep {
    let w_max = modes.stiffest.value;
    if integrator.unconditionally_stable() || w_max <= 0.0 {
        // A-stable: |R(z)| = 1/|1 − z| ≤ 1 on the whole left half-plane. One XPBD projection
        // of a spring is a backward-Euler step of it.
        return StableStep {
            integrator,
            dt_secs: Some(f64::INFINITY),
            limit: None,
            dashpot_line_secs: None,
        };
    }
    let points = region(modes);
    let grows = |h: f64| {
        points
            .iter()
            .copied()
            .find(|&(w, g)| integrator.amplification(w, g / (2.0 * w), h) > 1.0 + 1e-12)
    };
    // Every scheme here is unstable by ωdt = 4. A scheme that grows at ωdt = 0.01 grows at any
    // practical step (forward Euler and RK2 on an undamped mode).
    let probe = 1e-2 / w_max;
    let needs_damping = integrator.stable_dt(w_max, 0.0).is_none();
    let weak = |line: Option<f64>| StableStep {
        integrator,
        dt_secs: None,
        limit: Some(weak_damping(modes)),
        dashpot_line_secs: line,
    };
    if grows(probe).is_some() {
        return weak(None);
    }
    let (mut good, mut bad) = (probe, 4.0 / w_max);
    let mut culprit = grows(bad).unwrap_or((w_max, modes.most_damped.value));
    for _ in 0..60 {
        let mid = (good * bad).sqrt();
        match grows(mid) {
            None => good = mid,
            Some(p) => {
                bad = mid;
                culprit = p;
            }
        }
    }
    if needs_damping {
        return weak(Some(good));
    }
    StableStep {
        integrator,
        dt_secs: Some(good),
        limit: Some(limit_at(modes, integrator, good, culprit)),
        dashpot_line_secs: None,
    }
}

fn weak_damping(modes: &Modes) -> Limit {
    let (ratio_s, source) = modes
        .ratios
        .map_or((0.0, Source::AirDrag), |r| (r.least_s, r.least));
    Limit::WeakDamping { ratio_s, source }
}

/// Which limit the oscillator that first grows past `dt` shows. Overdamped, or held to a clearly
/// smaller step than it would be without its damping: the damping binds. Unstable without its
/// damping: the scheme needs damping, and too little of it binds. Otherwise the stiffness does.
fn limit_at(modes: &Modes, integrator: Integrator, dt: f64, (w, g): (f64, f64)) -> Limit {
    let overdamped = g >= 2.0 * w;
    match integrator.stable_dt(w, 0.0) {
        Some(u) if overdamped || (g > 0.0 && dt < 0.95 * u) => damping(modes),
        None if overdamped => damping(modes),
        None => weak_damping(modes),
        Some(_) => Limit::Stiffness {
            omega_rad_per_s: modes.stiffest.value,
            mass: modes.stiffest.mass,
            source: modes.stiffest.source,
        },
    }
}

fn damping(modes: &Modes) -> Limit {
    Limit::Damping {
        rate_per_s: modes.most_damped.value,
        mass: modes.most_damped.mass,
        source: modes.most_damped.source,
    }
}

/// Every integrator's estimate, in [`Integrator::ALL`]'s order, with the sweeps of `options`.
pub fn stable_steps(modes: &Modes, options: &StepOptions) -> Vec<StableStep> {
    Integrator::ALL
        .iter()
        .map(|&i| stable_step_with(modes, i, options))
        .collect()
}
