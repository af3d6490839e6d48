//! Classic Runge–Kutta: fourth order.

use super::descriptor::{Amplification, Explicit, Scheme, Solve, StableStep};
use super::oscillator::Oscillator;

pub const SCHEME: Scheme = Scheme {
    name: "rk4",
    title: "RK4",
    order: 4,
    solve: Solve::Explicit(Explicit::Staged),
    stable_step: StableStep::Limited,
    amplification: Amplification::Step(step),
};

fn step(o: &Oscillator, [x, v, _]: [f64; 3]) -> [f64; 3] {
    let dt = o.dt;
    let (k1x, k1v) = (v, o.acc(x, v));
    let (k2x, k2v) = (
        v + 0.5 * dt * k1v,
        o.acc(x + 0.5 * dt * k1x, v + 0.5 * dt * k1v),
    );
    let (k3x, k3v) = (
        v + 0.5 * dt * k2v,
        o.acc(x + 0.5 * dt * k2x, v + 0.5 * dt * k2v),
    );
    let (k4x, k4v) = (v + dt * k3v, o.acc(x + dt * k3x, v + dt * k3v));
    [
        x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
        v + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v),
        0.0,
    ]
}
