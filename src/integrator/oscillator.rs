//! The linear test oscillator `x'' = -ω² x - 2ζω x'` on which each scheme's stability is
//! judged: a scheme's one step on it is a 3 × 3 linear map, and the step is stable while the
//! map's spectral radius is at most 1.

/// The oscillator at one step: angular frequency `omega` (rad/s), damping ratio `zeta`, step
/// `dt` (s).
#[derive(Debug, Clone, Copy)]
pub struct Oscillator {
    pub omega: f64,
    pub zeta: f64,
    pub dt: f64,
}

impl Oscillator {
    /// The acceleration at position `x` and velocity `v`.
    pub fn acc(&self, x: f64, v: f64) -> f64 {
        -self.omega * self.omega * x - 2.0 * self.zeta * self.omega * v
    }
}

/// One step of a scheme on the oscillator, written exactly as the backends apply the scheme.
/// The state is (x, v, a): `a` is what velocity Verlet keeps from the step before (the
/// acceleration at the new position and the *predicted* velocity: both backends evaluate the
/// force once a step and reuse it); the other schemes ignore it and return 0 there.
pub type OneStep = fn(&Oscillator, [f64; 3]) -> [f64; 3];

/// Spectral radius of `step`: the largest root of the characteristic polynomial of its 3 × 3
/// matrix.
pub fn radius_of_step(step: OneStep, o: &Oscillator) -> f64 {
    let column = |k: usize| {
        let mut unit = [0.0; 3];
        unit[k] = 1.0;
        step(o, unit)
    };
    let (c0, c1, c2) = (column(0), column(1), column(2));
    let m = |r: usize, c: usize| [c0, c1, c2][c][r];
    // det(zI − M) = z³ − t z² + s z − d.
    let t = m(0, 0) + m(1, 1) + m(2, 2);
    let s = m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0) + m(0, 0) * m(2, 2) - m(0, 2) * m(2, 0)
        + m(1, 1) * m(2, 2)
        - m(1, 2) * m(2, 1);
    let d = m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1))
        - m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
        + m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
    cubic_spectral_radius(-t, s, -d)
}

/// The principal square root of re + i·im.
pub fn complex_sqrt(re: f64, im: f64) -> (f64, f64) {
    let modulus = re.hypot(im);
    let r = (0.5 * (modulus + re)).max(0.0).sqrt();
    let i = (0.5 * (modulus - re)).max(0.0).sqrt();
    (r, if im < 0.0 { -i } else { i })
}

/// The largest modulus of the roots of z³ + a z² + b z + c: one real root by bisection (a
/// cubic always has one), then the quadratic left after dividing it out.
fn cubic_spectral_radius(a: f64, b: f64, c: f64) -> f64 {
    if c == 0.0 {
        // z (z² + a z + b): a scheme that keeps no acceleration between steps has the root 0,
        // which the bisection below would chase through 200 halvings towards zero.
        return quadratic_spectral_radius(a, b);
    }
    let p = |z: f64| ((z + a) * z + b) * z + c;
    // Cauchy's bound holds every root.
    let bound = 1.0 + a.abs().max(b.abs()).max(c.abs());
    let (mut lo, mut hi) = (-bound, bound);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        // No float lies between them: the rest of the 200 would change nothing.
        if mid <= lo || mid >= hi {
            break;
        }
        if p(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let r = 0.5 * (lo + hi);
    // z³ + a z² + b z + c = (z − r)(z² + q1 z + q0).
    let (q1, q0) = (a + r, b + r * (a + r));
    r.abs().max(quadratic_spectral_radius(q1, q0))
}

/// The largest modulus of the roots of z² + q1 z + q0.
fn quadratic_spectral_radius(q1: f64, q0: f64) -> f64 {
    let disc = q1 * q1 / 4.0 - q0;
    if disc >= 0.0 {
        let sq = disc.sqrt();
        (-q1 / 2.0 + sq).abs().max((-q1 / 2.0 - sq).abs())
    } else {
        q0.abs().sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Forward Euler on the undamped oscillator multiplies by 1 ± iωh: ρ = √(1 + (ωh)²), with
    /// the root 0 of the acceleration it does not keep (the quadratic's path). Cubics whose
    /// roots are known take the bisection's.
    #[test]
    fn spectral_radii_match_their_closed_forms() {
        let euler: OneStep = |o, [x, v, _]| [x + o.dt * v, v + o.dt * o.acc(x, v), 0.0];
        for wdt in [1e-3, 0.1, 1.0, 3.0] {
            let o = Oscillator {
                omega: 1.0,
                zeta: 0.0,
                dt: wdt,
            };
            let r = radius_of_step(euler, &o);
            assert!(
                (r - (1.0 + wdt * wdt).sqrt()).abs() < 1e-12,
                "ωh = {wdt}: ρ = {r}"
            );
        }
        // (z + 3/4)(z² − 0.2 z + 0.05) = z³ + 0.55 z² − 0.1 z + 0.0375: the complex pair has
        // modulus √0.05, so the real root's 3/4 is the radius.
        assert!((cubic_spectral_radius(0.55, -0.1, 0.0375) - 0.75).abs() < 1e-12);
        // (z − 0.1)(z² + 0.9²): the pair ±0.9i is the radius.
        assert!((cubic_spectral_radius(-0.1, 0.81, -0.081) - 0.9).abs() < 1e-12);
    }
}
