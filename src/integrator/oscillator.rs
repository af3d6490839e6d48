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
    let p = |z: f64| ((z + a) * z + b) * z + c;
    // Cauchy's bound holds every root.
    let bound = 1.0 + a.abs().max(b.abs()).max(c.abs());
    let (mut lo, mut hi) = (-bound, bound);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if p(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let r = 0.5 * (lo + hi);
    // z³ + a z² + b z + c = (z − r)(z² + q1 z + q0).
    let (q1, q0) = (a + r, b + r * (a + r));
    let disc = q1 * q1 / 4.0 - q0;
    let quadratic = if disc >= 0.0 {
        let sq = disc.sqrt();
        (-q1 / 2.0 + sq).abs().max((-q1 / 2.0 - sq).abs())
    } else {
        q0.abs().sqrt()
    };
    r.abs().max(quadratic)
}
