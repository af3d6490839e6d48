//! The contact law: how the damping of a penalty contact sets the coefficient of restitution of
//! an impact. The scene's validation reads its bound ([`MIN_RESTITUTION`]); the model turns a
//! scene's restitution into a damping ratio.

/// Largest contact damping ratio: more would need a much smaller step (the damper's rate
/// 2ζω grows past the spring's ω), so the least restitution a contact can have is
/// [`MIN_RESTITUTION`].
pub const MAX_CONTACT_DAMPING_RATIO: f64 = 2.0;

/// The restitution at [`MAX_CONTACT_DAMPING_RATIO`], rounded up: `restitution_of_damping_ratio(2.0)`
/// is 0.0478.
pub const MIN_RESTITUTION: f32 = 0.05;

/// How many times its allowed depth (`max_depth_m`, half the finest grid spacing) a mass may
/// have sunk within a step before the post-step safeguard's projection of it counts as deep: it
/// passed a whole spacing, where the layer beneath it was, and putting it back flattens the body
/// (`cpu::Projected::deep`; the shaders' `DEEP_SHARE` override, contact_projection.wgsl).
pub const DEEP_SHARE: f32 = 2.0;

/// Coefficient of restitution of one impact on a penalty contact (spring k, damper 2ζ√(km)) that
/// pushes but never pulls: the contact ends when its force reaches zero, before the spring is
/// back at rest, so the bounce is larger than the linear oscillator's e = exp(−ζπ/√(1−ζ²))
/// (Schwager & Pöschel, Granular Matter 2007). In units of the contact's ω and the impact
/// speed, depth d(t) solves d″ = −d − 2ζd′ from d = 0, d′ = 1; the force d + 2ζd′ vanishes at
/// t*, and the mass leaves at speed |d′(t*)|.
pub fn restitution_of_damping_ratio(z: f64) -> f64 {
    if z <= 0.0 {
        return 1.0;
    }
    if z < 1.0 {
        let w = (1.0 - z * z).sqrt();
        let a = 1.0 - 2.0 * z * z;
        // ω t*: where tan(ωt) = −2ζω / (1 − 2ζ²), in (0, π].
        let wt = if a > 0.0 {
            std::f64::consts::PI - (2.0 * z * w / a).atan()
        } else if a < 0.0 {
            (2.0 * z * w / -a).atan()
        } else {
            std::f64::consts::FRAC_PI_2
        };
        let t = wt / w;
        return ((-z * t).exp() * (wt.cos() - z / w * wt.sin())).abs();
    }
    if z == 1.0 {
        // d = t e^{−t}: the force vanishes at t = 2.
        return (-2.0f64).exp();
    }
    let s = (z * z - 1.0).sqrt();
    let (r1, r2) = (-z + s, -z - s);
    let t = ((1.0 + 2.0 * z * r2) / (1.0 + 2.0 * z * r1)).ln() / (r1 - r2);
    ((r1 * (r1 * t).exp() - r2 * (r2 * t).exp()) / (r1 - r2)).abs()
}

/// The damping ratio whose impact keeps restitution `e` ([`restitution_of_damping_ratio`] is
/// continuous and decreasing, so bisection finds it); `e` at or below [`MIN_RESTITUTION`]'s
/// exact value gives [`MAX_CONTACT_DAMPING_RATIO`] (validation refuses less than 0.05).
pub fn damping_ratio_for_restitution(e: f32) -> f32 {
    let e = f64::from(e);
    if e >= 1.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0f64, MAX_CONTACT_DAMPING_RATIO);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if restitution_of_damping_ratio(mid) > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restitution_round_trips_through_damping_ratio() {
        for e in [0.05f32, 0.1, 0.135, 0.3, 0.5, 0.9] {
            let z = f64::from(damping_ratio_for_restitution(e));
            let back = restitution_of_damping_ratio(z);
            assert!((back - f64::from(e)).abs() < 1e-5, "e={e} back={back}");
        }
        assert_eq!(damping_ratio_for_restitution(1.0), 0.0);
        // Critical damping still bounces back at e^−2 (the contact lets go at t = 2/ω).
        assert!((restitution_of_damping_ratio(1.0) - (-2.0f64).exp()).abs() < 1e-12);
        // Continuous through critical damping, from both sides.
        for z in [1.0 - 1e-6, 1.0 + 1e-6] {
            assert!((restitution_of_damping_ratio(z) - (-2.0f64).exp()).abs() < 1e-5);
        }
        assert!(
            restitution_of_damping_ratio(MAX_CONTACT_DAMPING_RATIO) < f64::from(MIN_RESTITUTION)
        );
    }

    #[test]
    fn restitution_closed_form_matches_an_integrated_impact() {
        // d'' = -max(d + 2ζd', 0) from d = 0, d' = 1, integrated finely with RK4 until it leaves.
        for z in [0.1f64, 0.456, 0.8, 1.5] {
            let f = |d: f64, v: f64| -(d + 2.0 * z * v).max(0.0);
            let (mut d, mut v, h) = (0.0f64, 1.0f64, 1e-5);
            while d >= 0.0 {
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
