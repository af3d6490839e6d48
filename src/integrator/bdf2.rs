//! Second-order backward differentiation (BDF2): implicit Euler's Newton–CG solve, taken from a
//! blend of the last two states over two thirds of the step (`physics::BackwardStep`); second
//! order, stable at any dt, with far less numerical damping than implicit Euler at large
//! steps. Its first step is an implicit Euler step.

use super::descriptor::{Amplification, Scheme, Solve, StableStep};
use super::oscillator::{Oscillator, complex_sqrt};

pub const SCHEME: Scheme = Scheme {
    name: "bdf2",
    title: "BDF2",
    order: 2,
    solve: Solve::Newton { history: true },
    stable_step: StableStep::Any {
        why: "any in theory (A-stable on linear springs, second order: it damps slow motion far \
              less than implicit Euler; on springs extremely stiff against the step take \
              implicit, whose damping absorbs what an inexact step leaves)",
    },
    amplification: Amplification::Radius(radius),
};

/// BDF2's spectral radius on the test oscillator: on each mode y' = λ y it steps by the roots
/// of (3/2 − hλ) ρ² − 2ρ + 1/2 = 0, ρ = (2 ± √(1 + 2hλ)) / (3 − 2hλ). The oscillator's two
/// eigenvalues λ = ω(−ζ ± √(ζ² − 1)) are conjugate when underdamped, and so are their roots.
fn radius(o: &Oscillator) -> f64 {
    let (omega, zeta, dt) = (o.omega, o.zeta, o.dt);
    let disc = zeta * zeta - 1.0;
    let lambdas = if disc >= 0.0 {
        let s = disc.sqrt();
        [(omega * (-zeta + s), 0.0), (omega * (-zeta - s), 0.0)]
    } else {
        let s = (-disc).sqrt();
        [(-omega * zeta, omega * s), (-omega * zeta, -omega * s)]
    };
    let mut radius = 0.0f64;
    for (re, im) in lambdas {
        let (zr, zi) = (dt * re, dt * im);
        let root = complex_sqrt(1.0 + 2.0 * zr, 2.0 * zi);
        let denominator = (3.0 - 2.0 * zr, -2.0 * zi);
        let d2 = denominator.0 * denominator.0 + denominator.1 * denominator.1;
        for sign in [1.0, -1.0] {
            let (nr, ni) = (2.0 + sign * root.0, sign * root.1);
            radius = radius.max(((nr * nr + ni * ni) / d2).sqrt());
        }
    }
    radius
}
