//! Backward (implicit) Euler, solved by preconditioned conjugate gradients: first order, stable
//! at any dt (it damps), for stiff scenes and large steps.

use super::descriptor::{Amplification, Scheme, Solve, StableStep};
use super::oscillator::Oscillator;

pub const SCHEME: Scheme = Scheme {
    name: "implicit",
    title: "implicit Euler",
    order: 1,
    solve: Solve::Newton { history: false },
    stable_step: StableStep::Any {
        why: "any in theory (A-stable on linear springs; it damps, so accuracy still wants small steps)",
    },
    amplification: Amplification::Step(backward_euler_step),
};

/// v₁ = v₀ + h a(x₀ + h v₁, v₁), solved exactly for the linear oscillator. (VBD's block solve
/// of a lone linear oscillator is the same, exact in one sweep.)
pub fn backward_euler_step(o: &Oscillator, [x, v, _]: [f64; 3]) -> [f64; 3] {
    let (w, dt) = (o.omega, o.dt);
    let v1 = (v - dt * w * w * x) / (1.0 + 2.0 * o.zeta * w * dt + w * w * dt * dt);
    [x + dt * v1, v1, 0.0]
}
