//! The contact law: how the damping of a penalty contact sets the coefficient of restitution of
//! an impact. The scene's validation reads its range; the model turns a scene's restitution into
//! a damping ratio.

/// A restitution of 0 is critical damping (ζ = 1): the impact ends at rest on the surface.
pub const MIN_RESTITUTION: f32 = 0.0;

/// How many times its allowed depth (`max_depth_m`, half the finest grid spacing) a mass may
/// have sunk within a step before the post-step safeguard's projection of it counts as deep: it
/// passed a whole spacing, where the layer beneath it was, and putting it back flattens the body
/// (`cpu::Projected::deep`; the shaders' `DEEP_SHARE` override, contact_projection.wgsl).
pub const DEEP_SHARE: f32 = 2.0;

/// Coefficient of restitution of one impact on a Kelvin–Voigt contact (spring k, damper
/// 2ζ√(km)) that is on while its force k·d − c·ḋ pushes (`cpu::law::contact_normal_force`):
/// exp(−πζ / √(1 − ζ²)), the linear oscillator's, for ζ < 1, and 0 from critical damping on.
/// In units of the contact's ω and the impact speed, the force F = d + 2ζd′ obeys the same
/// equation as the depth, F″ = −F − 2ζF′, from F = 0, F′ = 1: it is zero again after half a
/// damped period, π / √(1 − ζ²), when the mass leaves at exp(−πζ / √(1 − ζ²)) (never, once
/// ζ ≥ 1: it comes to rest on the surface). A contact switched on only inside the surface
/// would jump by the damper's force at the touch and let go early, before its spring is back at
/// rest: a larger bounce (Schwager & Pöschel, Granular Matter 2007), and no solution for
/// Newton's method to find where a step lands a mass just past the touch.
pub fn restitution_of_damping_ratio(z: f64) -> f64 {
    if z <= 0.0 {
        return 1.0;
    }
    if z >= 1.0 {
        return 0.0;
    }
    (-std::f64::consts::PI * z / (1.0 - z * z).sqrt()).exp()
}

/// The damping ratio whose impact keeps restitution `e` (the inverse of
/// [`restitution_of_damping_ratio`]): −ln e / √(π² + ln² e), 1 (critical) for e = 0.
pub fn damping_ratio_for_restitution(e: f32) -> f32 {
    let e = f64::from(e);
    if e >= 1.0 {
        return 0.0;
    }
    if e <= 0.0 {
        return 1.0;
    }
    let l = -e.ln();
    (l / (std::f64::consts::PI * std::f64::consts::PI + l * l).sqrt()) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restitution_round_trips_through_damping_ratio() {
        for e in [0.0f32, 0.05, 0.1, 0.135, 0.3, 0.5, 0.9] {
            let z = f64::from(damping_ratio_for_restitution(e));
            let back = restitution_of_damping_ratio(z);
            assert!(
                (back - f64::from(e)).abs() < 1e-6,
                "e={e} z={z} back={back}"
            );
        }
        assert_eq!(damping_ratio_for_restitution(1.0), 0.0);
        assert_eq!(damping_ratio_for_restitution(0.0), 1.0);
        // Continuous into critical damping.
        assert!(restitution_of_damping_ratio(1.0 - 1e-6) < 1e-6);
    }

    #[test]
    fn restitution_closed_form_matches_an_integrated_impact() {
        // d'' = −max(d + 2ζd', 0) from above where the contact begins (d = −2ζ) at d' = 1,
        // integrated finely with RK4 until the contact has acted and lets go.
        for z in [0.1f64, 0.456, 0.8, 0.95] {
            let f = |d: f64, v: f64| -(d + 2.0 * z * v).max(0.0);
            let (mut d, mut v, h) = (-2.5f64, 1.0f64, 1e-5);
            let mut touched = false;
            while !(touched && d + 2.0 * z * v <= 0.0) {
                touched |= d + 2.0 * z * v > 0.0;
                let (k1x, k1v) = (v, f(d, v));
                let (k2x, k2v) = (v + 0.5 * h * k1v, f(d + 0.5 * h * k1x, v + 0.5 * h * k1v));
                let (k3x, k3v) = (v + 0.5 * h * k2v, f(d + 0.5 * h * k2x, v + 0.5 * h * k2v));
                let (k4x, k4v) = (v + h * k3v, f(d + h * k3x, v + h * k3v));
                d += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            }
            let closed = restitution_of_damping_ratio(z);
            assert!(
                (-v - closed).abs() < 1e-4,
                "ζ = {z}: integrated {}, closed form {closed}",
                -v
            );
        }
    }
}
