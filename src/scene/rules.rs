//! What every check of a scene's values shares: the failure type, numbers that must be finite or
//! positive, the f32 resolution rule for springs, the mass limit, and a body's spring constants.

use super::format_body::{Body, SpringKind};

pub(super) type Check = Result<(), (String, String)>;

/// Upper bound on the masses one scene may hold: far beyond any GPU's storage limits, low enough
/// that an absurd grid is refused before it is allocated.
pub const MAX_MASSES: u64 = 1 << 26;

/// The most sweeps (XPBD's iterations of a substep, VBD's of a step) a setting may ask for:
/// room for a converged VBD reference (100 000 sweeps), and a bound on what one step costs and
/// on the GPU's plan of it (a dispatch per colour and sweep), so that no setting makes a step
/// that cannot end. Past it, a run is refused, naming the setting.
pub const MOST_SWEEPS: u32 = 100_000;

pub(super) fn fail<T>(
    field: impl Into<String>,
    message: impl Into<String>,
) -> Result<T, (String, String)> {
    Err((field.into(), message.into()))
}

pub(super) fn finite(field: &str, v: f64) -> Check {
    if v.is_finite() {
        Ok(())
    } else if v.is_nan() {
        fail(field, "must be a finite number, got nan")
    } else {
        // The file's value was read as f32: 1e300 arrives here as inf.
        fail(
            field,
            format!(
                "must be finite and within f32's range (±3.4e38), got {} (a value beyond that \
                 range reads as infinite)",
                if v > 0.0 { "inf" } else { "-inf" }
            ),
        )
    }
}

pub(super) fn positive(field: &str, v: f64) -> Check {
    finite(field, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        fail(field, format!("must be greater than zero, got {v}"))
    }
}

pub(super) fn non_negative(field: &str, v: f64) -> Check {
    finite(field, v)?;
    if v >= 0.0 {
        Ok(())
    } else {
        fail(field, format!("must be zero or more, got {v}"))
    }
}

pub(super) fn finite3(field: &str, v: [f32; 3]) -> Check {
    for (i, c) in v.iter().enumerate() {
        finite(&format!("{field}[{i}]"), f64::from(*c))?;
    }
    Ok(())
}

/// Each spring kind's parameters, and the plasticity and tearing of its springs.
pub(super) fn springs(f: &str, b: &Body) -> Check {
    let kind = |name: &str, k: &Option<SpringKind>| -> Check {
        if let Some(k) = k {
            positive(
                &format!("{f}.springs.{name}.stiffness_n_per_m"),
                f64::from(k.stiffness_n_per_m),
            )?;
            non_negative(
                &format!("{f}.springs.{name}.damping_n_s_per_m"),
                f64::from(k.damping_n_s_per_m),
            )?;
        }
        Ok(())
    };
    kind("structural", &b.springs.structural)?;
    kind("shear", &b.springs.shear)?;
    kind("bending", &b.springs.bending)?;
    if let Some(p) = &b.plasticity {
        positive(
            &format!("{f}.plasticity.yield_strain"),
            f64::from(p.yield_strain),
        )?;
        positive(
            &format!("{f}.plasticity.creep_per_s"),
            f64::from(p.creep_per_s),
        )?;
        if p.yield_strain >= 1.0 {
            return fail(
                format!("{f}.plasticity.yield_strain"),
                format!(
                    "must be below 1 (a spring squeezed by 100% has no length left), got {}",
                    p.yield_strain
                ),
            );
        }
    }
    if let Some(t) = &b.tearing {
        positive(&format!("{f}.tearing.max_strain"), f64::from(t.max_strain))?;
        if let Some(p) = &b.plasticity
            && t.max_strain <= p.yield_strain
        {
            return fail(
                format!("{f}.tearing.max_strain"),
                format!(
                    "is {} but plasticity.yield_strain is {}: springs would break before they yield; \
                     make max_strain larger than yield_strain, or drop [plasticity]",
                    t.max_strain, p.yield_strain
                ),
            );
        }
    }
    Ok(())
}

/// How many f32 steps (ulps) of its ends' coordinates a spring must span at least: its strain is
/// then resolved to 1/64 (1.6%) or better. Shorter, and f32 rounding of the positions alone makes
/// the force noise, or (at a few ulps and below) puts both ends on one point.
pub const MIN_SPRING_ULPS: f64 = 64.0;

/// The farthest from the origin a body may start, in metres. The state is f32: beyond this a
/// mass's spring lengths squared, its energies (k L², m g h) and its speeds over a step leave
/// the range and resolution the solvers and the ledger need (a 64-mass cube at spacing_m = 1e30
/// once went to infinite strain in its first step). Bodies of hair, cloth and jello are metres
/// across; a kilometre-scale scene fits a thousand times over.
pub const LARGEST_REACH_M: f64 = 1e6;

/// A body that starts up to `far` metres from the origin, checked against `LARGEST_REACH_M`;
/// `field` is the value to change.
pub(super) fn within_reach(field: &str, far: f64, fix: &str) -> Check {
    if far <= LARGEST_REACH_M {
        return Ok(());
    }
    fail(
        field.to_owned(),
        format!(
            "places the body up to {far:.3e} m from the origin, beyond the {LARGEST_REACH_M:.0e} m \
             a body may start at (f32 positions, energies and strains lose their range and \
             resolution there): {fix}"
        ),
    )
}

/// The fastest a body may start, in m/s: the speed at which a run counts as runaway and stops
/// (`backend::RUNAWAY_SPEED_M_PER_S`, held equal by an assertion there). A body started faster
/// would stop at its first step.
pub const MAX_START_SPEED_M_PER_S: f32 = 1.0e4;

/// A start speed a run would stop at as runaway is refused before anything steps.
pub(super) fn start_speed(f: &str, b: &Body) -> Check {
    let speed = glam::Vec3::from(b.velocity_m_per_s).length();
    if speed <= MAX_START_SPEED_M_PER_S {
        return Ok(());
    }
    fail(
        format!("{f}.velocity_m_per_s"),
        format!(
            "a start speed of {speed:.3e} m/s is above the {MAX_START_SPEED_M_PER_S:.0e} m/s at \
             which a run counts as runaway and stops: nothing in a mass-spring scene moves that \
             fast; give a slower velocity"
        ),
    )
}

/// Relative spacing of f32 numbers: one ulp of x is at most |x| · 2⁻²³.
pub(super) const F32_EPSILON: f64 = 1.0 / 8_388_608.0;
