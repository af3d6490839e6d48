//! Explicit (forward) Euler: first order, gains energy on undamped oscillation.

use super::descriptor::{Amplification, Explicit, Scheme, Solve, StableStep};
use super::oscillator::Oscillator;

pub const SCHEME: Scheme = Scheme {
    name: "euler",
    title: "forward Euler",
    order: 1,
    solve: Solve::Explicit(Explicit::OneUpdate { symplectic: false }),
    stable_step: StableStep::Limited,
    amplification: Amplification::Step(step),
};

fn step(o: &Oscillator, [x, v, _]: [f64; 3]) -> [f64; 3] {
    [x + o.dt * v, v + o.dt * o.acc(x, v), 0.0]
}
