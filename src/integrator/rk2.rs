//! Runge–Kutta midpoint: second order.

use super::descriptor::{Amplification, Explicit, Scheme, Solve, StableStep};
use super::oscillator::Oscillator;

pub const SCHEME: Scheme = Scheme {
    name: "rk2",
    title: "RK2",
    order: 2,
    solve: Solve::Explicit(Explicit::Staged),
    stable_step: StableStep::Limited,
    amplification: Amplification::Step(step),
};

fn step(o: &Oscillator, [x, v, _]: [f64; 3]) -> [f64; 3] {
    let dt = o.dt;
    let (xm, vm) = (x + 0.5 * dt * v, v + 0.5 * dt * o.acc(x, v));
    [x + dt * vm, v + dt * o.acc(xm, vm), 0.0]
}
