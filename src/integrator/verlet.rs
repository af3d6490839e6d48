//! Velocity Verlet: second order, symplectic for conservative forces.

use super::descriptor::{Amplification, Explicit, Scheme, Solve, StableStep};
use super::oscillator::Oscillator;

pub const SCHEME: Scheme = Scheme {
    name: "verlet",
    title: "velocity Verlet",
    order: 2,
    solve: Solve::Explicit(Explicit::Staged),
    stable_step: StableStep::Limited,
    amplification: Amplification::Step(step),
};

/// src/cpu/integrate.rs: verlet_drift, the force at (x₁, v + h a), verlet_kick.
fn step(o: &Oscillator, [x, v, a]: [f64; 3]) -> [f64; 3] {
    let dt = o.dt;
    let kicked = v + 0.5 * dt * a;
    let x1 = x + dt * kicked;
    let a1 = o.acc(x1, v + dt * a);
    [x1, kicked + 0.5 * dt * a1, a1]
}
